"""python3 -m fdv.report: the page and every PNG it names, decoded as images."""
import json
import re
import shutil
import subprocess
import sys

import matplotlib.pyplot as plt
import numpy as np

import fdv
from fdv.report import read_timing


def test_report_files_decode_as_images(cli_results, dataset, workdir):
    out = workdir / "report"
    subprocess.run([sys.executable, "-m", "fdv.report", str(cli_results), "--truth", str(dataset), "--out", str(out)],
                   check=True, capture_output=True)
    page = (out / "report.html").read_text()
    images = re.findall(r'<img src="([^"]+)"', page)
    expected = {"timeline.png", "prediction_error.png", "latency_histograms.png", "windows.png"}
    assert expected <= set(images)
    assert any(re.fullmatch(r"trajectory_track_\d+\.png", name) for name in images)  # a track in 3D
    for name in images:
        img = plt.imread(out / name)
        assert img.ndim == 3 and img.shape[0] > 100 and img.shape[1] > 100
        assert np.std(img[..., :3]) > 0.01, name  # not a blank canvas


def test_report_without_truth(cli_results, workdir):
    out = workdir / "report_no_truth"
    subprocess.run([sys.executable, "-m", "fdv.report", str(cli_results), "--out", str(out)], check=True,
                   capture_output=True)
    assert (out / "report.html").exists() and (out / "timeline.png").exists()


def test_timing_csv_has_one_row_per_window_and_the_summary_counts(cli_results):
    timing = read_timing(cli_results)
    windows = [json.loads(line) for line in (cli_results / "detections.jsonl").read_text().splitlines()]
    assert len(timing) == len(windows) > 0
    assert [w["t_start"] for w in windows] == list(timing["t_start"])
    assert np.all(np.diff(timing["window"]) > 0)
    summary = json.loads((cli_results / "summary.json").read_text())["timing_ms"]
    for stage in timing.dtype.names[2:]:
        ran = timing[stage][np.isfinite(timing[stage])]
        if stage not in summary:  # a stage that ran in no window: every cell empty
            assert ran.size == 0, stage
            continue
        assert ran.size == summary[stage]["count"], stage
        assert (ran.min(), ran.max()) == (summary[stage]["min"], summary[stage]["max"]), stage


def test_report_without_timing_csv_draws_the_summary_bars(cli_results, workdir):
    """A results folder of an fdv before timing.csv: median, p99 and max bars from summary.json."""
    old = workdir / "old_results"
    old.mkdir(exist_ok=True)
    for name in ["detections.jsonl", "trajectories.jsonl", "predictions.jsonl", "summary.json"]:
        shutil.copy(cli_results / name, old / name)
    out = workdir / "report_old"
    subprocess.run([sys.executable, "-m", "fdv.report", str(old), "--out", str(out)], check=True, capture_output=True)
    images = re.findall(r'<img src="([^"]+)"', (out / "report.html").read_text())
    assert "latency.png" in images and "latency_histograms.png" not in images
    assert plt.imread(out / "latency.png").ndim == 3


def report(results, *args):
    return subprocess.run([sys.executable, "-m", "fdv.report", str(results), *map(str, args)], capture_output=True,
                          text=True)


def copy_of(cli_results, workdir, name, without=()):
    folder = workdir / name
    shutil.rmtree(folder, ignore_errors=True)
    shutil.copytree(cli_results, folder, ignore=shutil.ignore_patterns("windows", "report*", *without))
    return folder


def test_a_folder_without_summary_is_refused_naming_it(cli_results, workdir):
    folder = copy_of(cli_results, workdir, "no_summary", without=["summary.json"])
    done = report(folder)
    assert done.returncode == 1 and "Traceback" not in done.stderr
    assert f"{folder / 'summary.json'}: missing" in done.stderr


def test_a_truncated_file_is_named_with_its_line(cli_results, workdir):
    folder = copy_of(cli_results, workdir, "truncated")
    lines = (folder / "detections.jsonl").read_text().splitlines()
    (folder / "detections.jsonl").write_text("\n".join(lines[:3] + [lines[3][:10]]) + "\n")
    done = report(folder)
    assert done.returncode == 1 and "Traceback" not in done.stderr
    assert f"{folder / 'detections.jsonl'}: line 4:" in done.stderr
    (folder / "detections.jsonl").write_text("\n".join(lines) + "\n")
    (folder / "summary.json").write_text((cli_results / "summary.json").read_text()[:40])
    done = report(folder)
    assert done.returncode == 1 and f"{folder / 'summary.json'}: line" in done.stderr


def test_an_output_that_is_a_file_or_a_truth_of_another_scene_is_refused(cli_results, dataset, workdir):
    folder = copy_of(cli_results, workdir, "refusals")
    a_file = workdir / "a_file"
    a_file.write_text("")
    done = report(folder, "--out", a_file)
    assert done.returncode == 1 and f"{a_file}: exists and is not a folder" in done.stderr
    other = workdir / "another_scene"
    fdv.simulate("scene1_no_object", seed=2, out=str(other), duration=0.1, resolution=(346, 260))
    done = report(folder, "--truth", other)
    assert done.returncode == 1 and "another scene" in done.stderr and "Traceback" not in done.stderr


def test_a_run_without_windows_still_reports(cli_results, workdir):
    folder = copy_of(cli_results, workdir, "no_windows")
    (folder / "timing.csv").write_text((folder / "timing.csv").read_text().splitlines()[0] + "\n")
    assert read_timing(folder) is None
    done = report(folder)
    assert done.returncode == 0, done.stderr


# A decision written by hand: 4 m/s² along +y from 0.25 s for 0.3 s. The kinematic replay moves the
# body ½·4·0.15² = 0.045 m by 0.4 s and 4·(0.3²/2 + 0.3·0.25) = 0.48 m by 0.8 s, nothing before 0.25 s.
HAND_DODGE = {"t": 0.2, "effective_t": 0.25, "track": 1, "action": "dodge", "probability": 0.9,
              "miss_distance": 0.1, "committed": False, "reason": "by hand",
              "maneuver": {"acceleration_W": [0, 4, 0], "start_t": 0.25, "duration": 0.3,
                           "expected_clearance": 1, "probability_after": 0}}


def test_maneuver_offset_replays_the_set_points_exactly(cli_results, workdir):
    folder = copy_of(cli_results, workdir, "hand_dodge")
    (folder / "dodge.jsonl").write_text(json.dumps(HAND_DODGE) + "\n")
    offset = fdv.maneuver_offset(str(folder), [0.2, 0.4, 0.8])
    np.testing.assert_allclose(offset, [[0, 0, 0], [0, 0.045, 0], [0, 0.48, 0]], atol=1e-9)


def test_a_run_with_a_decision_gets_the_dodge_view(cli_results, dataset, workdir):
    folder = copy_of(cli_results, workdir, "dodge_view")
    (folder / "dodge.jsonl").write_text(json.dumps(HAND_DODGE) + "\n")
    out = workdir / "dodge_report"
    done = report(folder, "--truth", dataset, "--out", out)
    assert done.returncode == 0, done.stderr
    assert "dodge.png" in re.findall(r'<img src="([^"]+)"', (out / "report.html").read_text())
    img = plt.imread(out / "dodge.png")
    assert np.std(img[..., :3]) > 0.01
    # Without --truth there is no vehicle path to draw: no dodge view, no error.
    done = report(folder, "--out", workdir / "dodge_report_no_truth")
    assert done.returncode == 0 and not (workdir / "dodge_report_no_truth" / "dodge.png").exists()
