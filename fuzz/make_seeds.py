#!/usr/bin/python3
"""Builds the seed corpus of every fuzz target under BUILD_DIR/fuzz/seeds/TARGET/.

    /usr/bin/python3 fuzz/make_seeds.py BUILD_DIR

Seeds are small valid inputs that lead the fuzzer into each parser: prefixes of the real
recordings in ../shared/data/real (up to 64 KiB: readers treat a truncated tail as recoverable),
the inputs of ../shared/fuzz-findings (each must now end in a clear error), files this project
writes (simulated dataset folders, scenario files, ROS 1 bags written by ROS's own library), and
hand-encoded ROS messages. Nothing here is committed but fuzz/seeds/ (a few tiny files).
"""
import gzip
import os
import shutil
import sqlite3
import struct
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SHARED = ROOT.parent / "shared"
REAL = SHARED / "data" / "real"
FINDINGS = SHARED / "fuzz-findings"
PREFIX_BYTES = 64 * 1024


def target_dir(build, target):
    d = build / "fuzz" / "seeds" / target
    shutil.rmtree(d, ignore_errors=True)
    d.mkdir(parents=True)
    return d


def copy_prefix(src, dst, n=PREFIX_BYTES):
    dst.write_bytes(src.read_bytes()[:n])


def copy_findings(kind, out, pattern="*"):
    for f in sorted((FINDINGS / kind).glob(pattern)):
        if f.is_file() and f.stat().st_size <= PREFIX_BYTES * 2:
            shutil.copy(f, out / f"finding-{f.name}")


# --- ROS 2 bags: the real bags cut to their first messages, rewritten compactly ---------------
def trimmed_db3(src, dst, messages):
    con = sqlite3.connect(":memory:")
    con.execute(f"ATTACH DATABASE 'file:{src}?mode=ro' AS src")
    for (sql,) in con.execute("SELECT sql FROM src.sqlite_master WHERE type='table'").fetchall():
        con.execute(sql)
    for (table,) in con.execute("SELECT name FROM src.sqlite_master WHERE type='table'").fetchall():
        limit = f" ORDER BY id LIMIT {messages}" if table == "messages" else ""
        con.execute(f"INSERT INTO main.{table} SELECT * FROM src.{table}{limit}")
    con.commit()
    con.execute("DETACH DATABASE src")
    con.execute(f"VACUUM INTO '{dst}'")


def first_blobs(db3, n):
    con = sqlite3.connect(f"file:{db3}?mode=ro", uri=True)
    return [row[0] for row in con.execute(f"SELECT data FROM messages ORDER BY id LIMIT {n}")]


# --- ROS messages, encoded by hand from the message definitions --------------------------------
class Cdr:
    """OMG CDR (XCDR1) little endian, as ROS 2 stores messages: alignment from the payload start."""

    def __init__(self):
        self.b = bytearray()

    def align(self, n):
        self.b += b"\0" * (-len(self.b) % n)

    def put(self, fmt, *v):
        self.align(struct.calcsize(fmt[-1]))
        self.b += struct.pack("<" + fmt, *v)

    def string(self, s):
        data = s.encode() + b"\0"
        self.put("I", len(data))
        self.b += data

    def header(self, sec, nsec, frame="cam"):
        self.put("i", sec)
        self.put("I", nsec)
        self.string(frame)

    def doubles(self, *v):
        for x in v:
            self.put("d", x)

    def bytes(self):
        return b"\x00\x01\x00\x00" + bytes(self.b)


class Ros1:
    """ROS 1 serialization: little endian, packed."""

    def __init__(self):
        self.b = bytearray()

    def put(self, fmt, *v):
        self.b += struct.pack("<" + fmt, *v)

    def string(self, s):
        self.put("I", len(s))
        self.b += s.encode()

    def header(self, sec, nsec, frame="cam"):
        self.put("III", 7, sec, nsec)
        self.string(frame)

    def doubles(self, *v):
        self.put(f"{len(v)}d", *v)

    def bytes(self):
        return bytes(self.b)


EVENT_ARRAY, EVENT_PACKET, IMU, IMAGE, ODOMETRY, POSE_STAMPED, TRANSFORM_STAMPED = range(7)
CDR_BIT = 0x80


def imu(m):
    m.header(12, 345)
    m.doubles(0, 0, 0, 1, *[0] * 9, 0.1, 0.2, 0.3, *[0] * 9, 0, 0, 9.81, *[0] * 9)


def image(m, encoding, w, h, step, data):
    m.header(12, 345)
    m.put("I", h)
    m.put("I", w)
    m.string(encoding)
    m.put("B", 0)
    m.put("I", step)
    m.put("I", len(data))
    m.b += data


def odometry(m):
    m.header(12, 345, "world")
    m.string("body")
    m.doubles(1, 2, 3, 0, 0, 0, 1, *[0] * 36, 0.5, 0, 0, 0, 0, 0.1, *[0] * 36)


def pose_stamped(m):
    m.header(12, 345, "world")
    m.doubles(4, 5, 6, 0, 0, 0, 1)


def transform_stamped(m):
    m.header(12, 345, "world")
    m.string("ball")
    m.doubles(7, 8, 9, 0, 0, 0, 1)


def ros1_event_array():
    m = Ros1()
    m.header(12, 345)
    m.put("II", 260, 346)
    m.put("I", 3)
    for i in range(3):
        m.put("HHII?", 10 * i, 5 * i, 12, 346 + i, i % 2 == 0)
    return m.bytes()


def message_seeds(out):
    depth16 = struct.pack("<4H", 1000, 0, 2000, 65535)
    depth32 = struct.pack("<4f", 1.0, 0.0, float("nan"), 2.5)
    for name, fill in [("imu", (IMU, imu)), ("odometry", (ODOMETRY, odometry)),
                       ("pose", (POSE_STAMPED, pose_stamped)), ("transform", (TRANSFORM_STAMPED, transform_stamped)),
                       ("depth16", (IMAGE, lambda m: image(m, "16UC1", 2, 2, 4, depth16))),
                       ("depth32", (IMAGE, lambda m: image(m, "32FC1", 2, 2, 8, depth32)))]:
        kind, encode = fill
        for wire, cls, bit in [("cdr", Cdr, CDR_BIT), ("ros1", Ros1, 0)]:
            m = cls()
            encode(m)
            (out / f"{wire}-{name}").write_bytes(bytes([kind | bit]) + m.bytes())
    (out / "ros1-event_array").write_bytes(bytes([EVENT_ARRAY]) + ros1_event_array())
    for db3 in ["dvxplorer_libcaer_ros2.db3", "evt3_trigger_ros2.db3"]:
        # Two packets in one input: the evt3 decoder's state and the clock anchor span packets.
        blobs = first_blobs(REAL / db3, 2)
        (out / f"cdr-event_packet-{db3}").write_bytes(bytes([EVENT_PACKET | CDR_BIT]) + b"".join(blobs))


def hdf5_seeds(out):
    """Small HDF5 event files in both layouts, written with h5py (python3-h5py)."""
    import h5py
    import numpy as np
    n = 300
    t = np.cumsum(np.arange(n) % 7 * 400).astype("<i8")
    cd = np.zeros(n, dtype=[("x", "<u2"), ("y", "<u2"), ("p", "<i2"), ("t", "<i8")])
    cd["x"], cd["y"], cd["p"], cd["t"] = np.arange(n) % 640, np.arange(n) % 480, np.arange(n) % 2, t
    for name, opts in [("metavision.h5", {}), ("metavision_gzip.h5", {"compression": "gzip", "chunks": (64,)})]:
        with h5py.File(out / name, "w") as f:
            f.attrs["geometry"] = b"640x480"
            f.create_dataset("CD/events", data=cd, **opts)
            starts = np.searchsorted(t, np.arange(t[0], t[-1] + 1, 2000))
            index = np.zeros(len(starts) + 1, dtype=[("id", "<u8"), ("ts", "<i8")])
            index[0] = (0, -1)
            index["id"][1:], index["ts"][1:] = starts, t[starts] - t[0]
            f.create_dataset("CD/indexes", data=index).attrs["offset"] = str(-t[0]).encode()
    with h5py.File(out / "dsec.h5", "w") as f:
        for k, dtype in [("x", "<u2"), ("y", "<u2"), ("p", "u1"), ("t", "<u4")]:
            f.create_dataset(f"events/{k}", data=cd[k].astype(dtype))
        f.create_dataset("ms_to_idx", data=np.searchsorted(t, np.arange(0, t[-1] // 1000 + 2) * 1000).astype("<u8"))
        f.create_dataset("t_offset", data=np.int64(1_600_000_000_000_000))


# fuzz/ros_node_core_fuzzer.cpp: the index of each (stream, type) pair in its kMessages.
NODE_MESSAGES = {"event_array": 0, "event_packet": 2, "imu": 3, "depth16": 4, "depth32": 4, "odometry": 5,
                 "pose": 6, "transform": 7}


def node_core_seeds(messages_dir, out):
    """Runs of the message seeds, as the node's subscribers receive them: byte 0 the configuration
    (bit 0 CDR, bit 1 a configured sensor size), then per message its kind, 2-byte length, bytes."""
    for wire, cdr in [("ros1", 0), ("cdr", 1)]:
        run = b""
        for f in sorted(messages_dir.glob(f"{wire}-*")):
            kind = f.name.split("-")[1]
            body = f.read_bytes()[1:]
            if kind in NODE_MESSAGES and len(body) < 65536:
                run += struct.pack("<BH", NODE_MESSAGES[kind], len(body)) + body
        for sized in [0, 2]:
            (out / f"{wire}-run-{sized}").write_bytes(bytes([cdr | sized]) + run)


def perception_push_seeds(out):
    """fuzz/perception_push_fuzzer.cpp: a few valid pushes of each kind, in time order (ns)."""
    events = b"".join(struct.pack("<HHhq", 10 + i % 20, 5 + i % 30, 1 if i % 2 else -1, 1000 * i) for i in range(64))
    imu = struct.pack("<q6d", 0, 0.1, 0.0, 0.0, 0.0, 0.0, 9.81)
    odometry = struct.pack("<q13d", 0, 0, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0, 0, 0)
    depth = struct.pack("<q", 30_000) + struct.pack("<192H", *([1500] * 192))
    (out / "every-kind").write_bytes(bytes([1]) + imu + bytes([2]) + odometry + bytes([0, 64]) + events +
                                     bytes([3]) + depth)
    (out / "events").write_bytes(bytes([0, 64]) + events)
    for f in sorted((ROOT / "fuzz" / "seeds" / "perception_push").glob("*")):  # its findings, fixed
        shutil.copy(f, out)


def main():
    build = Path(sys.argv[1]).resolve()
    fdv = build / "fdv"

    out = target_dir(build, "fuzz_aedat4")
    for f in sorted(REAL.glob("*.aedat4")):
        copy_prefix(f, out / f.name)
    copy_findings("aedat4", out)

    out = target_dir(build, "fuzz_evt_raw")
    for f in sorted(REAL.glob("*.raw")):
        copy_prefix(f, out / f.name)
    copy_findings("evt2", out, "*.raw")

    hdf5_seeds(target_dir(build, "fuzz_hdf5"))

    out = target_dir(build, "fuzz_ros2_bag")
    for f in sorted(REAL.glob("*.db3")):
        trimmed_db3(f, out / f.name, 3)
    copy_findings("ros2", out, "*.db3")

    out = target_dir(build, "fuzz_ros_messages")
    message_seeds(out)

    node_core_seeds(out, target_dir(build, "fuzz_ros_node_core"))
    perception_push_seeds(target_dir(build, "fuzz_perception_push"))

    out = target_dir(build, "fuzz_ros1_bag")
    subprocess.run([str(build / "fuzz" / "fuzz_ros1_seed_writer"), str(out)], check=True)

    out = target_dir(build, "fuzz_calibration")
    shutil.copy(REAL / "davis346_00000133_calibration.xml", out)
    for f in sorted((ROOT / "fuzz" / "seeds" / "calibration").glob("*")):
        shutil.copy(f, out)
    copy_findings("calibration", out)

    out = target_dir(build, "fuzz_options")
    for f in sorted((ROOT / "fuzz" / "seeds" / "options").glob("*")):
        shutil.copy(f, out)
    copy_findings("options", out)

    out = target_dir(build, "fuzz_scenario")
    for preset in ["scene1_no_object", "scene2_ball", "fast_forward", "swing", "hover_headon", "dim"]:
        text = subprocess.run([str(fdv), "simulate", "--scenario", preset, "--print-config"], check=True,
                              capture_output=True).stdout
        (out / f"{preset}.yaml").write_bytes(text)

    # Folder formats: one seed per file kind, from a short simulated dataset (and its calibration).
    with tempfile.TemporaryDirectory() as tmp:
        # A 64x48 depth camera (fuzz/dataset_fuzzer.cpp's), so that a whole depth frame fits a seed;
        # its frames in both encodings.
        config = Path(tmp) / "small_depth.yaml"
        config.write_text("depth_camera: {width: 64, height: 48, fx: 38.57, fy: 38.57, cx: 32, cy: 24}\n")
        data = Path(tmp) / "dataset"
        for depth_format, folder in [("png", Path(tmp) / "png"), ("zstd", data)]:
            subprocess.run([str(fdv), "simulate", "--scenario", "fast_forward", "--duration", "0.03",
                            "--resolution", "64x48", "--config", str(config), "--depth-format", depth_format,
                            "--out", str(folder)], check=True, capture_output=True)
        for f in sorted((Path(tmp) / "png" / "depth").glob("*.png")):
            shutil.copy(f, data / "depth")
        shutil.copy(data / "calibration.yaml", build / "fuzz" / "seeds" / "fuzz_calibration")
        # Byte 0 picks the parser (fuzz/dataset_fuzzer.cpp).
        out = target_dir(build, "fuzz_dataset")
        kinds = {"dataset.yaml": 0, "events.bin": 1, "imu.csv": 2, "odometry.csv": 3, "truth/body.csv": 3,
                 "truth/objects.csv": 4, "depth.csv": 5}
        for f in sorted(data.rglob("*")):
            name = str(f.relative_to(data))
            kind = kinds.get(name, 6 if name.endswith((".png", ".zst")) else None)
            if f.is_file() and kind is not None:
                seed = bytes([kind]) + f.read_bytes()[:16 * 1024]
                (out / name.replace("/", "__")).write_bytes(seed)
    out = target_dir(build, "fuzz_rpg_text")
    for f in sorted((ROOT / "fuzz" / "seeds" / "rpg_text").glob("*")):
        shutil.copy(f, out)


if __name__ == "__main__":
    main()
