"""A results folder is replaced whole or left as it was; Ctrl-C and SIGTERM stop a run promptly;
one Perception used from two threads is serialised, never corrupted. The failures of an adversarial
test (shared/adversarial-findings: stale files, a partial folder beside an old summary, a run
deaf to Ctrl-C, a SIGSEGV when finish() races a push, a refused push that moved the time cursor)."""
import json
import os
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

import fdv
from conftest import FDV_CLI, cli

SLOW = ["--method", "contrast_max"]  # the slowest compensation: a run of some seconds to interrupt


def partial_folders(out):
    return sorted(p.name for p in out.parent.glob(f".{out.name}.partial-*"))


def wait_for(predicate, what, seconds=120):
    deadline = time.monotonic() + seconds
    while not predicate():
        if time.monotonic() > deadline:
            pytest.fail(f"timed out waiting for {what}")
        time.sleep(0.05)


def test_a_second_run_replaces_the_first_runs_files(dataset, workdir):
    out = workdir / "replaced"
    cli("run", dataset, "--out", out, "--visualize")
    assert list((out / "windows").glob("*.png")) and list(out.glob("track_*.tum"))
    (out / "metrics.json").write_text("{}")  # as `fdv eval` leaves it
    cli("run", dataset, "--out", out, "--method", "none")
    assert not (out / "windows").exists() and not (out / "metrics.json").exists()
    assert json.loads((out / "summary.json").read_text())["method"] == "none"
    fdv.run(dataset, out=out)
    assert json.loads((out / "summary.json").read_text())["method"] == "rotation_translation"
    assert partial_folders(out) == []


def test_a_folder_that_is_not_a_results_folder_is_not_replaced(dataset, workdir):
    out = workdir / "users_folder"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    run = cli("run", dataset, "--out", out, check=False)
    assert run.returncode == 1 and "is not a results folder" in run.stderr and str(out) in run.stderr
    assert sorted(p.name for p in out.iterdir()) == ["notes.txt"]


@pytest.mark.parametrize("signal_number", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_stops_fdv_run_and_leaves_the_earlier_results(dataset, workdir, signal_number):
    out = workdir / f"interrupted_{signal_number}"
    cli("run", dataset, "--out", out)
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    run = subprocess.Popen([FDV_CLI, "run", str(dataset), "--out", str(out), "--visualize", *SLOW],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    # Once a window's image is written, the run is past its start and its handler is installed.
    wait_for(lambda: any(out.parent.glob(f".{out.name}.partial-*/windows/*.png")), "the first window")
    run.send_signal(signal_number)
    _, err = run.communicate(timeout=120)
    assert run.returncode == 128 + signal_number, err
    assert "interrupted by signal" in err
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    assert partial_folders(out) == []


def test_ctrl_c_raises_keyboard_interrupt_in_fdv_run_and_leaves_the_folder(dataset, workdir):
    out = workdir / "python_interrupted"
    # Python turns SIGINT into KeyboardInterrupt only if it was not ignored when the interpreter
    # started, and a shell ignores it for the commands it starts in the background (`.ci/run &`):
    # the child installs the handler itself. It signals itself from a thread as soon as the run's
    # partial folder exists, within a millisecond of the run's start, before its last window.
    script = textwrap.dedent(f"""
        import os, pathlib, signal, threading, time, fdv
        signal.signal(signal.SIGINT, signal.default_int_handler)
        def interrupt_when_started():
            while not list(pathlib.Path({str(out.parent)!r}).glob({f".{out.name}.partial-*"!r})):
                time.sleep(0.001)
            os.kill(os.getpid(), signal.SIGINT)
        threading.Thread(target=interrupt_when_started, daemon=True).start()
        try:
            fdv.run({str(dataset)!r}, options={{"compensation": {{"method": "contrast_max"}}}}, out={str(out)!r})
            print("finished")
        except KeyboardInterrupt:
            print("KeyboardInterrupt")
        """)
    child = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=os.environ,
                           timeout=120)
    assert child.stdout.strip() == "KeyboardInterrupt", child.stderr
    assert not out.exists() and partial_folders(out) == []


def test_finish_racing_a_push_from_another_thread_is_serialised(dataset):
    script = textwrap.dedent(f"""
        import threading, numpy as np, fdv
        rec = fdv.open({str(dataset)!r})
        events = np.concatenate(list(rec.events()), dtype=fdv.EVENT_DTYPE)
        for attempt in range(10):
            p = fdv.Perception(rec.calibration)
            refused = []
            def pusher():
                try:
                    for i in range(0, len(events), 5000):
                        p.push_events(events[i:i + 5000])
                except ValueError as e:
                    refused.append(str(e))
            thread = threading.Thread(target=pusher)
            thread.start()
            p.finish()
            thread.join()
            assert all("used after finish()" in r for r in refused), refused
        print("survived")
        """)
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300, env=os.environ)
    assert done.returncode == 0 and done.stdout.strip() == "survived", done.stderr[-2000:]


def test_a_refused_push_changes_nothing(dataset):
    calibration = fdv.Calibration.load(str(dataset / "calibration.yaml"))
    events = np.zeros(1000, fdv.EVENT_DTYPE)
    events["t"], events["x"], events["y"], events["p"] = np.arange(1000) * 100, 10, 20, 1
    backwards = events.copy()
    backwards["t"][500] = 0
    p = fdv.Perception(calibration)
    with pytest.raises(ValueError, match="backwards at index 500"):
        p.push_events(backwards)
    p.push_events(events)  # the corrected array: the cursor did not move
    assert p.finish()["counts"]["events_read"] == 1000
