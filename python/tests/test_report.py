"""python3 -m fdv.report: the page and every PNG it names, decoded as images."""
import json
import re
import shutil
import subprocess
import sys

import matplotlib.pyplot as plt
import numpy as np

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
