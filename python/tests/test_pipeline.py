"""fdv.Perception and fdv.run against `fdv run` on the same simulated dataset; options round trips."""
import json
from pathlib import Path

import numpy as np
import pytest

import fdv
from conftest import cli, read_jsonl, real_file

FILES = {"windows": "detections.jsonl", "depth": "depth.jsonl", "trajectories": "trajectories.jsonl",
         "predictions": "predictions.jsonl", "dodge": "dodge.jsonl"}


def push_merged(perception, recording):
    for kind, data in recording.merged():
        if kind == "events":
            perception.push_events(data)
        elif kind == "imu":
            perception.push_imu(data)
        elif kind == "odometry":
            perception.push_odometry(data)
        elif kind == "depth":
            perception.push_depth(data[1], data[0])


def test_perception_from_python_equals_fdv_run(dataset, cli_results):
    rec = fdv.open(str(dataset), time_unit="ns")
    p = fdv.Perception(rec.calibration, fdv.PerceptionOptions(), time_unit="ns")
    push_merged(p, rec)
    results = p.finish()
    for key, file in FILES.items():
        assert results[key] == read_jsonl(cli_results / file), key
    # The run saw the ball: detections, 3D estimates and predictions to compare.
    assert sum(len(w["detections"]) for w in results["windows"]) > 0
    assert any(r["usable"] for r in results["trajectories"])
    assert results["predictions"]
    summary = json.loads((cli_results / "summary.json").read_text())
    assert results["counts"] == summary["counts"]


def test_callbacks_get_the_rows_in_order(dataset):
    rec = fdv.open(str(dataset), time_unit="ns")
    seen = []
    p = fdv.Perception(rec.calibration, time_unit="ns", on_window=lambda w: seen.append(("w", w["t_start"])),
                       on_estimate=lambda e: seen.append(("e", e["t"])))
    push_merged(p, rec)
    results = p.finish()
    assert results["windows"] == [] and results["trajectories"] == []  # given to the callbacks instead
    windows = [t for k, t in seen if k == "w"]
    assert windows == sorted(windows) and len(windows) == p.counts["windows"]
    assert any(k == "e" for k, _ in seen)


def test_fdv_run_equals_the_cli(dataset, cli_results, workdir):
    out = workdir / "python_run"
    results = fdv.run(dataset, out=out)
    assert isinstance(results, fdv.Results)
    for key, file in FILES.items():
        assert getattr(results, key) == read_jsonl(cli_results / file), key
    tum = sorted(p.name for p in out.glob("track_*.tum"))
    assert tum and tum == sorted(p.name for p in cli_results.glob("track_*.tum"))


def wall_clock_free(folder, name):
    """A results file without its wall-clock values: timing.csv's stage cells become whether the
    stage ran, summary.json loses "timing_ms"; any other file as it is."""
    path = folder / name
    if name == "timing.csv":
        rows = [line.split(",") for line in path.read_text().splitlines()]
        return [rows[0]] + [row[:2] + [cell != "" for cell in row[2:]] for row in rows[1:]]
    if name == "summary.json":
        summary = json.loads(path.read_text())
        del summary["timing_ms"]
        return summary
    return path.read_bytes()


@pytest.mark.parametrize("recording", ["simulated", "evt3_trigger_ros2.db3"])
def test_fdv_run_in_python_writes_the_folder_the_cli_writes(recording, dataset, workdir):
    # The real recording's reader drops records: the warnings that says so must reach both folders.
    source = dataset if recording == "simulated" else Path(real_file(recording))
    cli_out, python_out = workdir / f"same_folder_cli_{recording}", workdir / f"same_folder_python_{recording}"
    cli("run", source, "--out", cli_out)
    fdv.run(source, out=python_out)
    names = sorted(p.name for p in cli_out.iterdir())
    assert names == sorted(p.name for p in python_out.iterdir())
    for name in names:
        assert wall_clock_free(cli_out, name) == wall_clock_free(python_out, name), name
    warnings = json.loads((python_out / "summary.json").read_text())["warnings"]
    if recording != "simulated":
        assert any(w.startswith("the reader dropped") for w in warnings), warnings


def test_microsecond_events_run_too(dataset):
    # The default unit rounds the stamps to µs: the pipeline runs and sees the ball all the same.
    rec = fdv.open(str(dataset))
    p = fdv.Perception(rec.calibration)
    for chunk in rec.chunks():
        p.push_imu(chunk["imu"])
        p.push_odometry(chunk["odometry"])
        for t, depth in chunk["depth"]:
            p.push_depth(depth, t)
        p.push_events(chunk["events"])
    assert p.finish()["counts"]["detections"] > 0


def test_options_round_trip_yaml_and_dict():
    o = fdv.PerceptionOptions.from_dict({"window_ms": 7.5, "detector": {}, "tracking": {"gate_chi2": 12.0}})
    d = o.to_dict()
    assert d["window_ms"] == 7.5 and d["tracking"]["gate_chi2"] == 12.0
    assert fdv.PerceptionOptions.from_yaml(o.to_yaml()) == o
    assert fdv.PerceptionOptions.from_dict(d) == o
    assert fdv.PerceptionOptions.from_dict(d).to_dict() == d
    assert o != fdv.PerceptionOptions()
    assert fdv.options(None) == fdv.PerceptionOptions()


def test_options_yaml_is_the_clis(workdir):
    # `fdv run --print-config` prints the same YAML for the same file.
    config = workdir / "options.yaml"
    config.write_text("window_ms: 4\ntracking:\n  gate_chi2: 9\n")
    assert fdv.PerceptionOptions.load(str(config)).to_yaml() == cli("run", "--print-config", "--config", config).stdout
    assert fdv.options(config) == fdv.PerceptionOptions.load(str(config))


def test_calibration(dataset):
    calib = fdv.Calibration.load(str(dataset / "calibration.yaml"))
    assert (calib.width, calib.height) == (346, 260) and calib.has_depth_camera
    K = calib.K
    # A point on the optical axis projects to the principal point; one at x = z to cx + fx.
    px = calib.project(np.array([[0, 0, 2.0], [2.0, 0, 2.0], [0, 0, -1.0]]))
    assert px[0] == pytest.approx([K[0, 2], K[1, 2]])
    assert np.isnan(px[2]).all()
    assert calib.T_B_E.shape == (4, 4)


CALIBRATION_64x48 = """
event_camera:
  width: 64
  height: 48
  intrinsics: [60, 60, 32, 24]
  distortion: [0, 0, 0, 0, 0]
"""


def windows_of_scattered_events(more_options=None, **perception_args):
    """75 ms of events scattered over a 64x48 sensor without distortion (three 25 ms windows unless
    `more_options` says otherwise), run without compensation (so the compensated grid is the
    sensor's), `perception_args` given to fdv.Perception: the events and the window rows."""
    calib = fdv.Calibration.from_text(CALIBRATION_64x48)
    options = fdv.PerceptionOptions.from_dict(
        {"compensation": {"method": "none"}, "estimate_trajectories": False, "detector": {"hot_pixels": False},
         **(more_options or {})})
    rng = np.random.default_rng(7)
    n = 6000
    events = np.zeros(n, dtype=fdv.EVENT_DTYPE)
    events["t"] = np.sort(rng.integers(0, 75_000_000, n))  # [ns]
    events["x"] = rng.integers(0, 64, n)
    events["y"] = rng.integers(0, 48, n)
    events["p"] = 1
    p = fdv.Perception(calib, options, time_unit="ns", **perception_args)
    p.push_events(events)
    return events, p.finish()["windows"]


def test_window_images_are_the_time_images_of_its_events():
    # I is the count of each window's events per pixel and N their mean time per pixel, normalised
    # over the window's pixels with events (docs/DETECTION.md), computed here from the events alone.
    events, windows = windows_of_scattered_events(images=True)
    assert len(windows) == 3
    for w in windows:
        t0, t1 = round(w["t_start"] * 1e9), round(w["t_end"] * 1e9)
        e = events[(events["t"] >= t0) & (events["t"] < t1)]
        count = np.zeros((48, 64), np.int64)
        np.add.at(count, (e["y"], e["x"]), 1)
        time_sum = np.zeros((48, 64))
        np.add.at(time_sum, (e["y"], e["x"]), (e["t"] - t0) * 1e-9)
        fired = count > 0
        mean_time = time_sum[fired] / count[fired]
        normalized = (mean_time - mean_time.min()) / (mean_time.max() - mean_time.min())
        images = w["images"]
        assert images["count"].dtype == np.int32 and images["count"].shape == (48, 64)
        np.testing.assert_array_equal(images["count"], count)
        np.testing.assert_allclose(images["normalized"][fired], normalized, atol=1e-5)
        assert not images["normalized"][~fired].any()
        assert images["segmentation"].shape == images["preprocessed"].shape == (48, 64)
        assert images["gates"] == []  # no track: nothing expected anywhere


def test_window_images_hold_the_evidence_grid_of_the_window():
    # The evidence source's state (docs/DETECTION.md, "Evidence source"), one value per 8x8 cell:
    # each cell's fired pixels are the count image's pixels with an event in that cell.
    _, windows = windows_of_scattered_events(images=True)
    for w in windows:
        grid = w["images"]["sources"]["evidence"]
        assert sorted(grid) == ["evidence", "excess", "fired", "llr", "mean", "travel", "variance"]
        fired = (w["images"]["count"] > 0).reshape(6, 8, 8, 8).sum(axis=(1, 3))
        np.testing.assert_array_equal(grid["fired"], fired)
        assert grid["evidence"].shape == grid["mean"].shape == (6, 8) and grid["travel"].shape == (6, 8, 2)
        assert (grid["evidence"] >= 0).all()


def test_window_images_are_off_by_default():
    _, windows = windows_of_scattered_events()
    assert len(windows) == 3 and not any("images" in w for w in windows)


def test_overlapping_windows_each_hold_their_25_ms_of_events():
    # step_ms 5: a 25 ms window every 5 ms from the first event; each window's count image is the
    # count of the events in its own [t_start, t_end), computed here from the events alone.
    events, windows = windows_of_scattered_events({"step_ms": 5}, images=True)
    starts = [round(w["t_start"] * 1e9) for w in windows]
    first = int(events["t"][0])
    assert starts == [first + k * 5_000_000 for k in range(len(windows))]
    assert len(windows) == (int(events["t"][-1]) - first - 25_000_000) // 5_000_000 + 2  # + the flushed one
    for w in windows:
        t0, t1 = round(w["t_start"] * 1e9), round(w["t_end"] * 1e9)
        assert t1 - t0 == 25_000_000
        e = events[(events["t"] >= t0) & (events["t"] < t1)]
        count = np.zeros((48, 64), np.int64)
        np.add.at(count, (e["y"], e["x"]), 1)
        np.testing.assert_array_equal(w["images"]["count"], count)
