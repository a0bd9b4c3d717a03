"""Bad input: a Python exception with a clear message, never a crash; the C++ messages kept."""
import itertools
import json
import os
import shutil
import subprocess
import threading

import numpy as np
import pytest

import fdv
from conftest import FDV_CLI, cli, cli_json


@pytest.fixture(scope="module")
def perception(dataset):
    return fdv.Perception(fdv.Calibration.load(str(dataset / "calibration.yaml")))


def events(ts):
    a = np.zeros(len(ts), fdv.EVENT_DTYPE)
    a["t"], a["x"], a["y"], a["p"] = ts, 10, 20, 1
    return a


def test_errors_are_value_errors_with_the_cpp_message(workdir):
    assert issubclass(fdv.InputError, ValueError) and issubclass(fdv.ConfigError, ValueError)
    missing = workdir / "no_such_file.aedat4"
    with pytest.raises(fdv.InputError) as e:
        fdv.open(str(missing))
    assert str(e.value) in cli("info", missing, check=False).stderr


def test_unknown_option_key_same_message_as_cpp(workdir):
    config = workdir / "bad_options.yaml"
    config.write_text("detector:\n  no_such_key: 1\n")
    with pytest.raises(fdv.InputError) as e:
        fdv.PerceptionOptions.load(str(config))
    assert "key detector.no_such_key" in str(e.value)
    assert str(e.value) in cli("run", "--print-config", "--config", config, check=False).stderr
    with pytest.raises(fdv.InputError) as d:
        fdv.PerceptionOptions.from_dict({"detector": {"no_such_key": 1}})
    assert str(d.value) == str(e.value).replace(str(config), "<dict>")


def test_config_error():
    with pytest.raises(fdv.ConfigError, match="unknown scenario 'nope'"):
        fdv.simulate("nope", out="/nonexistent")
    with pytest.raises(fdv.InputError, match="window_ms"):
        fdv.PerceptionOptions.from_dict({"window_ms": -1})


@pytest.mark.parametrize("value", [float("nan"), float("inf"), -float("inf")])
def test_a_non_finite_option_names_its_key(value):
    # It used to surface as the JSON parser's "parse_error.101" at a byte, with no key.
    with pytest.raises(fdv.InputError, match=r"<dict>:key window_ms: not a finite number"):
        fdv.PerceptionOptions.from_dict({"window_ms": value})
    with pytest.raises(fdv.InputError, match=r"key tracking\.filter\.measurement_sigma_px: not a finite number"):
        fdv.PerceptionOptions.from_dict({"tracking": {"filter": {"measurement_sigma_px": value}}})


def test_wrong_dtype(perception):
    with pytest.raises(TypeError, match="push_events: expected an array of dtype"):
        perception.push_events(np.zeros(4, dtype=np.float64))
    with pytest.raises(TypeError, match="push_imu"):
        perception.push_imu(events([1]))


def test_non_contiguous(perception):
    with pytest.raises(ValueError, match="not contiguous"):
        perception.push_events(events(np.arange(10))[::2])
    with pytest.raises(ValueError, match="1-D"):
        perception.push_events(events(np.arange(4)).reshape(2, 2))


def test_unsorted_times(dataset):
    p = fdv.Perception(fdv.Calibration.load(str(dataset / "calibration.yaml")))
    with pytest.raises(ValueError, match="go backwards at index 2"):
        p.push_events(events([5, 6, 4]))
    p2 = fdv.Perception(fdv.Calibration.load(str(dataset / "calibration.yaml")))
    p2.push_events(events([5, 6]))
    with pytest.raises(ValueError, match="go backwards at index 0"):
        p2.push_events(events([3]))


def test_depth_of_the_wrong_shape(perception):
    with pytest.raises(ValueError, match=r"expected shape \(\d+, \d+\).*got \(10, 10\)"):
        perception.push_depth(np.zeros((10, 10), np.uint16), 0)
    with pytest.raises(TypeError, match="uint16"):
        perception.push_depth(np.zeros((10, 10), np.float32), 0)


def test_closed_reader(dataset):
    rec = fdv.open(str(dataset))
    it = iter(rec)
    next(it)
    rec.close()
    assert rec.closed
    with pytest.raises(ValueError, match="the recording is closed"):
        next(it)
    with pytest.raises(ValueError, match="the recording is closed"):
        rec.imu()
    with pytest.raises(ValueError, match="the recording is closed"):
        list(rec.events(delta_t=1000))


def test_perception_after_finish(dataset):
    p = fdv.Perception(fdv.Calibration.load(str(dataset / "calibration.yaml")))
    p.finish()
    for call in [lambda: p.push_events(events([1])), lambda: p.push_imu(np.zeros(1, fdv.IMU_DTYPE)),
                 lambda: p.push_odometry(np.zeros(1, fdv.ODOMETRY_DTYPE)), p.finish]:
        with pytest.raises(ValueError, match="used after finish"):
            call()


def test_bad_slicing_arguments(dataset):
    with pytest.raises(ValueError, match=r"delta_t must be in \(0, 1e15\] µs"):
        fdv.open(str(dataset)).events(delta_t=0)
    with pytest.raises(ValueError, match="time_unit must be"):
        fdv.open(str(dataset), time_unit="ms")


def test_packed_event_layout_is_accepted(dataset):
    # np.concatenate drops the padding of EVENT_DTYPE (numpy's structured promotion): accepted too.
    a = events([1, 2])
    packed = np.concatenate([a, a[:0]])
    assert packed.dtype.itemsize == 14
    p = fdv.Perception(fdv.Calibration.load(str(dataset / "calibration.yaml")))
    p.push_events(packed)
    p.finish()
    assert p.counts["events_read"] == 2


def test_fdv_info_into_a_full_disk_fails(dataset):
    # Output refused (a full disk, a closed pipe) is an error, not exit 0 with nothing written.
    with open("/dev/full", "w") as full:
        done = subprocess.run([FDV_CLI, "info", str(dataset)], stdout=full, stderr=subprocess.PIPE, text=True)
    assert done.returncode == 1 and "cannot write to standard output" in done.stderr


@pytest.mark.parametrize("name", ["imu.csv", "dataset.yaml", "calibration.yaml", "events.bin"])
def test_a_fifo_in_a_dataset_is_an_error_not_a_hang(dataset, workdir, name):
    copy = workdir / f"fifo_{name}"
    shutil.rmtree(copy, ignore_errors=True)
    shutil.copytree(dataset, copy)
    (copy / name).unlink()
    os.mkfifo(copy / name)
    done = subprocess.run([FDV_CLI, "info", str(copy)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 1 and f"{copy / name}: not a regular file" in done.stderr, done.stderr
    with pytest.raises(fdv.InputError, match="not a regular file"):
        fdv.open(str(copy))


def test_a_fifo_or_a_folder_given_as_a_file_is_named(dataset, workdir):
    fifo = workdir / "a_fifo.aedat4"
    if not fifo.exists():
        os.mkfifo(fifo)
    done = subprocess.run([FDV_CLI, "info", str(fifo)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 1 and "not a regular file" in done.stderr, done.stderr
    copy = workdir / "events_bin_folder"
    shutil.rmtree(copy, ignore_errors=True)
    shutil.copytree(dataset, copy)
    (copy / "events.bin").unlink()
    (copy / "events.bin").mkdir()
    with pytest.raises(fdv.InputError, match="events.bin: is a folder, not a file"):
        fdv.open(str(copy))


def test_fdv_eval_refuses_the_truth_of_another_scene(dataset, cli_results, workdir):
    other = workdir / "eval_another_scene"
    if not other.exists():
        fdv.simulate("scene1_no_object", seed=2, out=str(other), duration=0.1, resolution=(346, 260))
    done = subprocess.run([FDV_CLI, "eval", str(cli_results), "--truth", str(other)], capture_output=True, text=True)
    assert done.returncode == 1 and f"{other}: not the dataset the results were run on" in done.stderr, done.stderr
    smaller = workdir / "eval_smaller_camera"
    if not smaller.exists():
        fdv.simulate("scene2_ball", seed=3, out=str(smaller), duration=0.1, resolution=(240, 180))
    done = subprocess.run([FDV_CLI, "eval", str(cli_results), "--truth", str(smaller)], capture_output=True, text=True)
    assert done.returncode == 1 and "its camera is 240x180, the results' 346x260" in done.stderr, done.stderr
    assert subprocess.run([FDV_CLI, "eval", str(cli_results), "--truth", str(dataset)],
                          capture_output=True).returncode == 0


def test_a_corrupt_polarity_or_padding_in_events_bin_is_dropped_where_it_is(dataset, workdir):
    copy = workdir / "corrupt_records"
    shutil.rmtree(copy, ignore_errors=True)
    shutil.copytree(dataset, copy)
    data = bytearray((copy / "events.bin").read_bytes())
    header, record = 24, 16
    data[header + 100 * record + 12] = 7      # polarity byte 7
    data[header + 100010 * record + 14] = 1   # a padding byte set
    (copy / "events.bin").write_bytes(bytes(data))
    before = cli_json("info", dataset)
    after = cli_json("info", copy)
    assert after["events"] == before["events"] - 2
    dropped = after["report"]["dropped"]["events.bin: polarity not 0 or 1, or padding not zero"]
    assert dropped == {"count": 2, "first": f"byte {header + 100 * record}"}


def run_perception(rec, imu, odometry, events):
    p = fdv.Perception(rec.calibration, fdv.PerceptionOptions())
    p.push_imu(imu)
    p.push_odometry(odometry)
    p.push_events(events)
    return p.finish()


def test_perception_drops_and_counts_what_a_reader_would(dataset):
    # ../shared/adversarial-findings/py_perception_nan_quat.py: NaN and inf IMU, a pose with
    # qw = 5, a zero quaternion, a NaN position. Each is dropped, counted by reason with the first
    # one's place, and changes no result (the same run without those samples is the expectation).
    rec = fdv.open(str(dataset))
    ev = np.concatenate(list(rec.events()), dtype=fdv.EVENT_DTYPE)
    imu, odo = rec.imu(), rec.odometry()
    bad_imu = imu.copy()
    bad_imu["gx"][3], bad_imu["ax"][5] = np.nan, np.inf
    bad_odo = odo.copy()
    bad_odo["qw"][4] = 5.0
    bad_odo["qw"][6] = bad_odo["qx"][6] = bad_odo["qy"][6] = bad_odo["qz"][6] = 0.0
    bad_odo["px"][8] = np.nan
    keep_imu = np.ones(len(imu), bool)
    keep_imu[[3, 5]] = False
    keep_odo = np.ones(len(odo), bool)
    keep_odo[[4, 6, 8]] = False
    expected = run_perception(rec, imu[keep_imu], odo[keep_odo], ev)
    got = run_perception(rec, bad_imu, bad_odo, ev)
    for key in ("windows", "trajectories", "predictions", "dodge", "counts"):
        assert got[key] == expected[key], key
    assert expected["input_report"]["dropped"] == {}
    dropped = got["input_report"]["dropped"]
    assert dropped["imu: non-finite value"]["count"] == 2
    assert dropped["imu: non-finite value"]["first"].startswith("imu 3 (t ")
    assert dropped["odometry: quaternion is not unit length"]["count"] == 2
    assert dropped["odometry: quaternion is not unit length"]["first"].startswith("odometry 4 (t ")
    assert dropped["odometry: non-finite value"]["count"] == 1
    assert any(w.startswith("pushed imu: non-finite value: dropped") for w in got["warnings"])
    # All IMU non-finite: every sample dropped, so the run has no IMU and says so.
    all_nan = imu.copy()
    all_nan["gx"][:] = np.nan
    got = run_perception(rec, all_nan, odo, ev)
    assert got["input_report"]["dropped"]["imu: non-finite value"]["count"] == len(imu)
    counts = got["counts"]
    assert counts["imu"] == 0 and counts["windows_with_fallback_flag"]["imu missing"] == counts["windows"]


def test_perception_drops_an_event_at_a_corrupt_time(dataset):
    p = fdv.Perception(fdv.Calibration.load(str(dataset / "calibration.yaml")), time_unit="ns")
    p.push_events(events([-2**63, 1000, 2000, 2**63 - 1, 3000]))
    r = p.finish()
    assert r["counts"]["events_read"] == 3
    assert r["input_report"]["dropped"]["event: time out of range (corrupt)"] == {
        "count": 2, "first": f"event 0 (t {-2**63} ns)"}


def test_fdv_info_of_a_folder_whose_name_is_not_utf8(dataset, workdir):
    # Bytes \xff\xfe in the folder's name: shown as U+FFFD, as summary.json shows them.
    parent = bytes(workdir) + b"/bad\xff\xfename"
    os.makedirs(parent, exist_ok=True)
    copy = parent + b"/ds"
    if not os.path.exists(copy):
        shutil.copytree(bytes(dataset), copy)
    done = subprocess.run([FDV_CLI.encode(), b"info", copy], capture_output=True)
    assert done.returncode == 0, done.stderr
    info = json.loads(done.stdout.decode())
    assert info["path"].endswith("/bad\ufffd\ufffdname/ds") and info["events"] > 0


def edited_events(dataset, workdir, name, edit):
    """A copy of the dataset whose events.bin records (a numpy structured array) `edit` changed."""
    copy = workdir / name
    shutil.rmtree(copy, ignore_errors=True)
    shutil.copytree(dataset, copy)
    dt = np.dtype([("t", "<i8"), ("x", "<u2"), ("y", "<u2"), ("p", "u1"), ("pad", "V3")])
    data = (copy / "events.bin").read_bytes()
    records = np.frombuffer(data[24:], dt).copy()
    edit(records)
    (copy / "events.bin").write_bytes(data[:24] + records.tobytes())
    return copy


def test_an_event_at_a_corrupt_time_is_a_counted_drop(dataset, workdir):
    # make_cases.sh's ev_negtime: the first event at INT64_MIN, the 501st at INT64_MAX.
    def edit(r):
        r["t"][0], r["t"][500] = -2**63, 2**63 - 1
    copy = edited_events(dataset, workdir, "ev_negtime", edit)
    before, after = cli_json("info", dataset), cli_json("info", copy)
    assert after["events"] == before["events"] - 2
    assert after["duration_s"] < before["duration_s"] and after["first_t_s"] >= 0
    assert after["report"]["dropped"]["event time out of range (corrupt)"] == {"count": 2, "first": "byte 24"}
    slices = list(fdv.open(str(copy)).events(delta_t=1000))
    assert sum(len(s) for s in slices) == after["events"]


def test_delta_t_slices_skip_the_rest_of_a_long_gap(dataset, workdir):
    # A real jump of 1e6 s after event 1000 (every later event follows it): 1e12 slices of 1 ms.
    def edit(r):
        r["t"][1000:] += 10**15
    copy = edited_events(dataset, workdir, "ev_gap", edit)
    rec = fdv.open(str(copy), time_unit="ns")
    slices = list(itertools.islice(rec.events(delta_t=1000), 100000))
    assert len(slices) < 100000, "endless over the gap"
    times = np.concatenate(slices)["t"]
    assert len(times) == cli_json("info", copy)["events"]
    ends = np.array([s["t"][-1] for s in slices if len(s)])
    t0 = times[0]
    # Every slice is [t0 + kΔt, t0 + (k+1)Δt): each event's slice index is its time's.
    k = [(s["t"] - t0) // 10**6 for s in slices if len(s)]
    assert all(len(set(ks)) == 1 for ks in k) and all(np.diff([ks[0] for ks in k]) > 0)
    empty_run = max(len(list(g)) for e, g in itertools.groupby(len(s) == 0 for s in slices) if e)
    assert empty_run == 400
    assert ends[-1] == times[-1]


def test_a_drop_is_reported_at_its_own_record_not_its_chunks(dataset, workdir):
    # make_cases.sh's ev_back2: record 100000 goes backwards, record 100010 is outside the sensor;
    # both lie in the chunk of 65536 events that starts at record 65536 (byte 1048600).
    def edit(r):
        r["t"][100000] = r["t"][99999] - 1000
        r["x"][100010] = 9999
    copy = edited_events(dataset, workdir, "ev_back2", edit)
    dropped = cli_json("info", copy)["report"]["dropped"]
    assert dropped["event timestamp went backwards"] == {"count": 1, "first": f"byte {24 + 100000 * 16}"}
    assert dropped["event pixel outside the sensor"] == {"count": 1, "first": f"byte {24 + 100010 * 16}"}


def test_an_iterator_used_from_two_threads_refuses_the_second_not_races(dataset):
    # Each next() reads with the GIL released: two threads on one iterator would share its buffers.
    # A call that overlaps another raises, having consumed nothing: the events handed out by the
    # calls that ran are every event of the recording, once.
    total = fdv.open(str(dataset)).info["events"]
    it = fdv.open(str(dataset)).events(n_events=500)
    got, refused, other = [], [], []

    def drain():
        while True:
            try:
                got.append(len(next(it)))
            except StopIteration:
                return
            except RuntimeError as e:
                refused.append(str(e))
            except Exception as e:  # anything else is a failure
                other.append(repr(e))
                return

    threads = [threading.Thread(target=drain) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not other, other
    assert sum(got) == total
    assert all(r == "fdv.EventIterator: used from two threads at once; give each thread its own iterator"
               for r in refused), refused[:3]
