"""fdv.open: the event dtype, counts equal to `fdv info`, time slicing, the other streams."""
import numpy as np
import pytest

import fdv
from conftest import cli_json, real_file

REAL_RECORDINGS = ["davis346_ball_throw_person.aedat4", "davis346_flicker_noise.aedat4",
                   "dvxplorer_person_static.aedat4", "dvxplorer_libcaer_ros2.db3", "evt3_trigger_ros2.db3",
                   "gen3_sparks_evt2.raw", "gen41_street_evt3.raw"]


def test_event_dtype_is_metavisions_eventcd():
    d = fdv.EVENT_DTYPE
    assert d.itemsize == 16
    assert d.names == ("x", "y", "p", "t")
    assert {k: (str(v[0]), v[1]) for k, v in d.fields.items()} == {
        "x": ("uint16", 0), "y": ("uint16", 2), "p": ("int16", 4), "t": ("int64", 8)}
    # The layout numpy gives an aligned (x, y, p, t) record: the same dtype, so arrays interchange.
    assert d == np.dtype([("x", "<u2"), ("y", "<u2"), ("p", "<i2"), ("t", "<i8")], align=True)


@pytest.mark.parametrize("name", REAL_RECORDINGS)
def test_real_recording_counts_equal_fdv_info(name):
    path = real_file(name)
    expected = cli_json("info", path)
    with fdv.open(path) as rec:
        assert rec.info == expected
        chunks = list(rec)
        events = np.concatenate(chunks) if chunks else np.empty(0, fdv.EVENT_DTYPE)
        assert all(c.dtype == fdv.EVENT_DTYPE for c in chunks)
        assert len(events) == expected["events"]
        assert int(np.count_nonzero(events["p"] == 1)) == expected["events_on"]
        assert len(rec.imu()) == expected["imu"]["count"]
        assert [rec.width, rec.height] == expected["resolution"]
    if len(events):
        assert np.all(np.diff(events["t"]) >= 0)
        # t in µs: the first and last stamps of `fdv info` (seconds) to the microsecond.
        assert events["t"][0] == pytest.approx(expected["first_t_s"] * 1e6, abs=1)
        assert events["t"][-1] == pytest.approx(expected["last_t_s"] * 1e6, abs=1)


def test_nanoseconds_option():
    path = real_file("gen3_sparks_evt2.raw")
    us = np.concatenate(list(fdv.open(path)))
    ns = np.concatenate(list(fdv.open(path, time_unit="ns")))
    assert ns.dtype.fields.keys() == fdv.EVENT_DTYPE.fields.keys()
    np.testing.assert_array_equal(ns["t"] // 1000, us["t"])
    np.testing.assert_array_equal(ns[["x", "y", "p"]], us[["x", "y", "p"]])


@pytest.fixture(scope="module")
def all_events():
    path = real_file("davis346_ball_throw_person.aedat4")
    return path, np.concatenate(list(fdv.open(path, chunk_events=5000)))


def test_delta_t_slices(all_events):
    path, events = all_events
    dt = 7_000  # µs
    slices = list(fdv.open(path).events(delta_t=dt))
    t0 = events["t"][0]
    # Slice k holds exactly the events in [t0 + k·dt, t0 + (k+1)·dt), empty slices included.
    expected_counts = np.bincount((events["t"] - t0) // dt)
    assert [len(s) for s in slices] == list(expected_counts)
    for k, s in enumerate(slices):
        assert np.all((s["t"] >= t0 + k * dt) & (s["t"] < t0 + (k + 1) * dt))
    np.testing.assert_array_equal(np.concatenate(slices), events)


def test_n_events_slices(all_events):
    path, events = all_events
    slices = list(fdv.open(path).events(n_events=10_000))
    assert [len(s) for s in slices[:-1]] == [10_000] * (len(slices) - 1)
    assert 0 < len(slices[-1]) <= 10_000
    np.testing.assert_array_equal(np.concatenate(slices), events)


def test_mixed_slices_end_at_whichever_comes_first(all_events):
    path, events = all_events
    dt, n = 20_000, 3_000
    slices = list(fdv.open(path).events(delta_t=dt, n_events=n))
    assert max(len(s) for s in slices) == n
    np.testing.assert_array_equal(np.concatenate(slices), events)
    t0 = events["t"][0]
    for s in slices:  # a slice never straddles a Δt boundary
        if len(s):
            assert (s["t"][0] - t0) // dt == (s["t"][-1] - t0) // dt


def test_simulated_streams(dataset):
    truth = fdv.load_truth(str(dataset))
    with fdv.open(str(dataset)) as rec:
        info = rec.info
        imu, odometry, depth, objects = rec.imu(), rec.odometry(), rec.depth(), rec.ground_truth()
        assert rec.calibration is not None and rec.calibration.has_depth_camera
    assert imu.dtype == fdv.IMU_DTYPE and len(imu) == info["imu"]["count"]
    assert odometry.dtype == fdv.ODOMETRY_DTYPE and len(odometry) == info["odometry"]["count"]
    assert len(depth) == info["depth"]["count"]
    t, frame = depth[0]
    assert frame.dtype == np.uint16 and frame.ndim == 2
    assert 100 < np.median(frame[frame > 0]) < 20_000  # millimetres of a room-sized scene
    # Quaternions are unit; gravity is in the specific force of a hovering vehicle.
    q = np.stack([odometry[k] for k in ("qx", "qy", "qz", "qw")], axis=1)
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1, atol=1e-9)
    assert np.linalg.norm([imu["ax"].mean(), imu["ay"].mean(), imu["az"].mean()]) == pytest.approx(9.81, rel=0.05)
    assert truth["objects"].dtype == fdv.OBJECT_DTYPE and len(truth["objects"]) > 0
    assert len(objects) == info["ground_truth"]["count"]


def test_merged_is_in_time_order(dataset):
    last = -1
    kinds = set()
    for kind, data in fdv.open(str(dataset), time_unit="ns").merged():
        kinds.add(kind)
        t = data[0] if kind == "depth" else data["t"][0]
        assert t >= last
        last = data[0] if kind == "depth" else data["t"][-1]
    assert {"events", "imu", "odometry", "depth"} <= kinds


def test_depth_reads_the_same_from_either_encoding(tmp_path):
    """`depth_format` (as `fdv simulate --depth-format`): the same frames as Zstandard or PNG files;
    the PNGs read by matplotlib's own decoder equal what fdv reads from the Zstandard frames."""
    import matplotlib.image
    for depth_format in ("zstd", "png"):
        fdv.simulate("scene2_ball", seed=3, out=str(tmp_path / depth_format), duration=0.1,
                     resolution=(346, 260), depth_format=depth_format)
    zst, png = (fdv.open(str(tmp_path / f)).depth() for f in ("zstd", "png"))
    assert sorted(p.name for p in (tmp_path / "zstd" / "depth").iterdir())[0] == "000000.zst"
    assert len(zst) == len(png) >= 3
    for (t_z, d_z), (t_p, d_p) in zip(zst, png):
        assert t_z == t_p
        np.testing.assert_array_equal(d_z, d_p)
    first = matplotlib.image.imread(tmp_path / "png" / "depth" / "000000.png")  # 16-bit scaled to [0, 1]
    np.testing.assert_array_equal(np.rint(first * 65535).astype(np.uint16), zst[0][1])
    with pytest.raises(fdv.ConfigError, match="depth_format 'jpg'"):
        fdv.simulate("scene2_ball", out=str(tmp_path / "x"), duration=0.1, depth_format="jpg")
