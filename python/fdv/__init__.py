"""fast-dynamic-vision from Python: read any recording into numpy, run the perception pipeline and
the simulator, plot the results (``python3 -m fdv.report``).

    import fdv
    rec = fdv.open("run.aedat4")                  # any format `fdv info` reads
    for events in rec.events(delta_t=10_000):     # numpy arrays of fdv.EVENT_DTYPE, 10 ms slices
        ...
    results = fdv.run("dataset_dir")              # the pipeline, as `fdv run`
    results.windows[0]["detections"]              # dicts with the keys of detections.jsonl

Events use Metavision's EventCD layout (x <u2 @0, y <u2 @2, p <i2 @4, t <i8 @8; 16 bytes), t in
µs unless time_unit="ns". Errors of the library are fdv.InputError (a file's content) and
fdv.ConfigError (an option), both ValueError, with the C++ message.
"""
from dataclasses import dataclass, field
import os

from ._fdv import (EVENT_DTYPE, IMU_DTYPE, ODOMETRY_DTYPE, OBJECT_DTYPE, Calibration, ConfigError, InputError,
                   Perception, PerceptionOptions, Recording, load_truth, maneuver_offset, open, preset_names,
                   simulate)
from . import _fdv

__all__ = ["EVENT_DTYPE", "IMU_DTYPE", "ODOMETRY_DTYPE", "OBJECT_DTYPE", "Calibration", "ConfigError",
           "InputError", "Perception", "PerceptionOptions", "Recording", "Results", "load_truth", "maneuver_offset", "open",
           "options", "preset_names", "run", "simulate"]


@dataclass
class Results:
    """What fdv.run returns: the rows of each JSONL file of a results folder, as dicts."""
    windows: list = field(default_factory=list)       # detections.jsonl
    depth: list = field(default_factory=list)         # depth.jsonl
    trajectories: list = field(default_factory=list)  # trajectories.jsonl
    predictions: list = field(default_factory=list)   # predictions.jsonl
    dodge: list = field(default_factory=list)         # dodge.jsonl
    warnings: list = field(default_factory=list)
    counts: dict = field(default_factory=dict)        # summary.json "counts"
    reader_report: dict = field(default_factory=dict)
    options: dict = field(default_factory=dict)       # the effective options (after the sensor policy)


def options(value=None):
    """PerceptionOptions from None (defaults), a PerceptionOptions, a dict or a YAML file's path."""
    if value is None:
        return PerceptionOptions()
    if isinstance(value, PerceptionOptions):
        return value
    if isinstance(value, dict):
        return PerceptionOptions.from_dict(value)
    if isinstance(value, (str, os.PathLike)):
        return PerceptionOptions.load(os.fspath(value))
    raise TypeError(f"options: expected PerceptionOptions, dict or a YAML path, got {type(value).__name__}")


def run(path, calib=None, options=None, *, out=None, events_topic="", imu_topic="", depth_topic="",
        odometry_topic="", ground_truth_topic="", resolution=None):
    """The whole pipeline over a recording, as `fdv run`: the same sensor policy (fallbacks and
    warnings) and, with `out`, the same results folder. `calib`: a path or a Calibration (default:
    the recording's own); `options`: see fdv.options(); `resolution=(width, height)`: the sensor
    size of a file that does not give it (HDF5's DSEC layout), as `fdv run --resolution WxH`.
    Returns Results."""
    calibration, name = None, ""
    if isinstance(calib, Calibration):
        calibration, name = calib, "<Calibration>"
    elif calib is not None:
        name = os.fspath(calib)
        calibration = Calibration.load(name)
    reader_options = _fdv._ReaderOptions()
    reader_options.events_topic, reader_options.imu_topic = events_topic, imu_topic
    reader_options.depth_topic, reader_options.odometry_topic = depth_topic, odometry_topic
    reader_options.ground_truth_topic = ground_truth_topic
    reader_options.set_resolution(resolution)
    d = _fdv._run(os.fspath(path), calibration, name, _options(options), os.fspath(out) if out else "", reader_options)
    return Results(**d)


_options = options
