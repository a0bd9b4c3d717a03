"""python3 -m fdv.report: the page and every PNG it names, decoded as images."""
import re
import subprocess
import sys

import matplotlib.pyplot as plt
import numpy as np


def test_report_files_decode_as_images(cli_results, dataset, workdir):
    out = workdir / "report"
    subprocess.run([sys.executable, "-m", "fdv.report", str(cli_results), "--truth", str(dataset), "--out", str(out)],
                   check=True, capture_output=True)
    page = (out / "report.html").read_text()
    images = re.findall(r'<img src="([^"]+)"', page)
    expected = {"timeline.png", "prediction_error.png", "latency.png", "windows.png"}
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
