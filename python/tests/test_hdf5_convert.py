"""HDF5 events and `fdv convert`, checked with foreign tools: h5py writes the inputs fdv reads and
reads the HDF5 files fdv writes; `fdv convert` round trips through fdv's own readers."""
import json
from pathlib import Path

import h5py
import numpy as np
import pytest

import fdv
from conftest import cli, cli_json, real_file

EPOCH_US = 1_600_000_000_000_000


def events_of(path, **kw):
    chunks = list(fdv.open(str(path), **kw))
    return np.concatenate(chunks) if chunks else np.empty(0, fdv.EVENT_DTYPE)


def some_events(n=20_000, t0=EPOCH_US):
    rng = np.random.default_rng(5)
    ev = np.zeros(n, fdv.EVENT_DTYPE)
    ev["x"], ev["y"], ev["p"] = rng.integers(0, 640, n), rng.integers(0, 480, n), rng.integers(0, 2, n)
    ev["t"] = t0 + np.cumsum(rng.integers(0, 30, n))
    return ev


def write_metavision(path, ev, **dataset_options):
    """CD/events and CD/indexes as Metavision lays them out, written by h5py."""
    with h5py.File(path, "w") as f:
        f.attrs["geometry"] = "640x480"  # a variable-length string, as h5py writes a str
        f.create_dataset("CD/events", data=ev, **dataset_options)
        t = ev["t"]
        starts = np.searchsorted(t, np.arange(t[0], t[-1] + 1, 2000))
        index = np.zeros(len(starts) + 1, dtype=[("id", "<u8"), ("ts", "<i8")])
        index[0] = (0, -1)
        index["id"][1:], index["ts"][1:] = starts, t[starts] - t[0]
        f.create_dataset("CD/indexes", data=index).attrs["offset"] = str(-t[0])


@pytest.mark.parametrize("options", [{}, {"compression": "gzip", "chunks": (4096,)},
                                     {"compression": 32004, "chunks": (4096,)},   # LZ4, hdf5-filter-plugin
                                     {"compression": 32001, "chunks": (4096,)}],  # Blosc, Debian's plugin
                         ids=["plain", "gzip", "lz4", "blosc"])
def test_h5py_metavision_file_reads_event_for_event(tmp_path, options):
    ev = some_events()
    write_metavision(tmp_path / "cd.h5", ev, **options)
    with fdv.open(str(tmp_path / "cd.h5"), chunk_events=3000) as rec:
        assert (rec.width, rec.height) == (640, 480)
        assert np.array_equal(np.concatenate(list(rec)), ev)


def test_h5py_dsec_file_needs_the_resolution(tmp_path):
    ev = some_events(t0=0)
    path = tmp_path / "events.h5"
    with h5py.File(path, "w") as f:
        for k, dtype in [("x", "<u2"), ("y", "<u2"), ("p", "u1"), ("t", "<u4")]:
            f.create_dataset(f"events/{k}", data=ev[k].astype(dtype), compression="gzip")
        f.create_dataset("ms_to_idx", data=np.searchsorted(ev["t"], np.arange(0, ev["t"][-1] // 1000 + 2) * 1000))
        f.create_dataset("t_offset", data=np.int64(EPOCH_US))
    with pytest.raises(fdv.InputError, match="--resolution WxH"):
        fdv.open(str(path))
    got = events_of(path, resolution=(640, 480))
    expected = ev.copy()
    expected["t"] += EPOCH_US
    assert np.array_equal(got, expected)
    assert cli_json("info", path, "--resolution", "640x480")["events"] == len(ev)
    # the pipeline too, as `fdv run --resolution`: every event reaches a window
    with pytest.raises(fdv.InputError, match="--resolution WxH"):
        fdv.run(path)
    results = fdv.run(path, resolution=(640, 480))
    assert sum(w["events"] for w in results.windows) == len(ev)
    with pytest.raises(ValueError, match="sides in 1..65535"):
        fdv.run(path, resolution=(0, 480))


def test_convert_raw_to_hdf5_reads_the_same_with_h5py_and_fdv(tmp_path):
    raw = real_file("gen41_street_evt3.raw")
    original = events_of(raw)
    for gzip in ["0", "4"]:
        out = tmp_path / f"street{gzip}.h5"
        summary = cli_json("convert", raw, "--to", "hdf5", out, "--gzip", gzip)
        assert summary["events"] == len(original)
        assert summary["times_floored_to_us"] == 0  # EVT 3.0 times are whole µs
        with h5py.File(out, "r") as f:
            assert f.attrs["geometry"] == b"1280x720"
            assert np.array_equal(f["CD/events"][:], original)  # fdv.EVENT_DTYPE is Metavision's
            assert f["CD/events"].compression == ("gzip" if gzip == "4" else None)
        assert np.array_equal(events_of(out), original)


def test_convert_to_evt3_keeps_absolute_times(tmp_path):
    ev = some_events()
    ev["t"][10_000:] += 40_000_000  # a 40 s gap: the 24-bit time wraps twice
    write_metavision(tmp_path / "in.h5", ev)
    summary = cli_json("convert", tmp_path / "in.h5", "--to", "evt3", tmp_path / "out.raw")
    assert summary["events"] == len(ev)
    assert np.array_equal(events_of(tmp_path / "out.raw"), ev)
    # the real EVT 3.0 recording through our writer: the same events again
    raw = real_file("gen41_street_evt3.raw")
    cli("convert", raw, "--to", "evt3", tmp_path / "street.raw")
    assert np.array_equal(events_of(tmp_path / "street.raw"), events_of(raw))


def test_convert_start_end_and_what_is_left_out(tmp_path):
    aedat = real_file("davis346_ball_throw_person.aedat4")
    info = cli_json("info", aedat)
    summary = cli_json("convert", aedat, "--to", "hdf5", tmp_path / "all.h5")
    assert summary["not_written"]["imu"] == info["imu"]["count"] > 0  # HDF5 here holds events only
    ev = events_of(aedat)
    t0 = min(ev["t"][0], fdv.open(aedat).imu()["t"][0])
    window = ev[(ev["t"] >= t0 + 500_000) & (ev["t"] < t0 + 1_000_000)]
    summary = cli_json("convert", aedat, "--to", "hdf5", tmp_path / "cut.h5", "--start", "0.5", "--end", "1.0")
    assert summary["events"] == len(window)
    assert np.array_equal(events_of(tmp_path / "cut.h5"), window)


def test_convert_to_a_format_that_cannot_hold_the_sensor_is_an_error(tmp_path):
    ev = some_events(100)
    with h5py.File(tmp_path / "big.h5", "w") as f:
        f.attrs["geometry"] = "4096x3072"
        f.create_dataset("CD/events", data=ev)
    r = cli("convert", tmp_path / "big.h5", "--to", "evt3", tmp_path / "out.raw", check=False)
    assert r.returncode == 1
    assert "EVT 3.0 addresses pixels with 11 bits: sensor size 4096x3072 is outside 1..2048" in r.stderr


def test_convert_to_aedat4_keeps_events_and_imu(tmp_path, dataset):
    # a DAVIS346 recording: events event for event, IMU sample for sample (float32 g and deg/s)
    aedat = real_file("davis346_ball_throw_person.aedat4")
    summary = cli_json("convert", aedat, "--to", "aedat4", tmp_path / "copy.aedat4", "--compression", "zstd")
    original, copy = fdv.open(aedat), fdv.open(str(tmp_path / "copy.aedat4"))
    assert summary["events"] == len(events_of(aedat)) and summary["imu"] == len(original.imu()) > 0
    assert np.array_equal(events_of(tmp_path / "copy.aedat4"), events_of(aedat))
    a, b = original.imu(), copy.imu()
    assert np.array_equal(a["t"], b["t"])
    for field in ("gx", "gy", "gz", "ax", "ay", "az"):
        assert np.allclose(a[field], b[field], rtol=1e-6, atol=1e-6)
    # a simulated dataset: depth and odometry are what AEDAT 4.0 cannot hold, and are counted
    summary = cli_json("convert", dataset, "--to", "aedat4", tmp_path / "sim.aedat4")
    info = cli_json("info", dataset)
    assert summary["not_written"]["depth"] == info["depth"]["count"] > 0
    assert summary["not_written"]["odometry"] == info["odometry"]["count"] > 0
    assert summary["imu"] == info["imu"]["count"]
    assert np.array_equal(events_of(tmp_path / "sim.aedat4"), events_of(dataset))


def test_hdf5_is_read_through_the_plugin_the_package_carries(tmp_path):
    """The HDF5 reader is a plugin (docs/BUILDING.md "Format plugins"): an installed package
    loads the copy in its own fdv_plugins folder, the build tree's package the build's."""
    write_metavision(tmp_path / "cd.h5", some_events(100))
    assert len(events_of(tmp_path / "cd.h5")) == 100
    loaded = {line.split()[-1] for line in open("/proc/self/maps") if line.rstrip().endswith("/libfdv_hdf5.so")}
    assert len(loaded) == 1, loaded
    carried = Path(fdv.__file__).resolve().parent / "fdv_plugins" / "libfdv_hdf5.so"
    if carried.exists():
        assert loaded == {str(carried)}
    else:
        assert next(iter(loaded)).endswith("/fdv_plugins/libfdv_hdf5.so")
