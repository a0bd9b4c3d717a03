"""Bad input: a Python exception with a clear message, never a crash; the C++ messages kept."""
import os
import shutil
import subprocess

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
    with pytest.raises(ValueError, match="delta_t must be > 0"):
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
