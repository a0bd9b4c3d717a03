#!/usr/bin/python3
"""fdv_ros_node against a real ROS master (README "ROS 1 node").

    node_replay_test.py BUILD_DIR WORK_DIR [--events-as event_array|event_packet] [--rate R]
                        [--resolution WxH]

Simulates a scene, exports it as a ROS 1 bag (`fdv export --to ros1-bag`), runs `fdv run` on that
bag for the reference, then starts roscore on a free loopback port, the node and `rosbag record`,
plays the bag with `rosbag play -r R`, and compares what the node published with the reference:
the same windows (times, status, boxes, centers) and the same trajectory estimates. At rate 1
(real time) it checks only that no input message was dropped and reports the event rate and the
latency; the node then does not await depth (its default), so the latency is the live one.
Everything it starts runs in its own process group and is stopped on exit; each step is bounded.
"""
import argparse
import json
import math
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time

import rosbag  # Debian's python3-rosbag

SCENARIO = ("hover_headon", "1")
TIMEOUT_S = 120


def free_port():
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Processes:
    """Started processes, each in its own group; stopped with SIGINT, then SIGKILL."""

    def __init__(self, env, log_dir):
        self.env, self.log_dir, self.started = env, log_dir, []

    def start(self, name, args):
        log = open(os.path.join(self.log_dir, name + ".log"), "w")
        p = subprocess.Popen(args, env=self.env, stdin=subprocess.DEVNULL, stdout=log, stderr=subprocess.STDOUT,
                             start_new_session=True)
        self.started.append((name, p))
        return p

    def stop(self, p, timeout=10):
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGINT)
            try:
                p.wait(timeout)
            except subprocess.TimeoutExpired:
                os.killpg(p.pid, signal.SIGKILL)
                p.wait()

    def stop_all(self):
        for _, p in reversed(self.started):
            self.stop(p)

    def log(self, name):
        with open(os.path.join(self.log_dir, name + ".log")) as f:
            return f.read()


def run(args, env=None, stdout=None, stderr=None):
    """Runs a step to its end, bounded: on timeout its whole process group is killed."""
    print("+", " ".join(args), flush=True)
    p = subprocess.Popen(args, env=env, stdin=subprocess.DEVNULL, stdout=stdout, stderr=stderr,
                         start_new_session=True)
    try:
        rc = p.wait(TIMEOUT_S)
    except subprocess.TimeoutExpired:
        os.killpg(p.pid, signal.SIGKILL)
        p.wait()
        raise RuntimeError(f"timed out after {TIMEOUT_S} s: {' '.join(args)}")
    if rc != 0:
        raise RuntimeError(f"exit code {rc}: {' '.join(args)}")


def wait_until(predicate, what, timeout=30):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return
        time.sleep(0.2)
    raise RuntimeError("timed out waiting for " + what)


def jsonl(path):
    with open(path) as f:
        return [json.loads(line) for line in f if line.strip()]


def close(a, b, tol, what):
    if isinstance(a, (list, tuple)):
        assert len(a) == len(b), f"{what}: {a} vs {b}"
        for x, y in zip(a, b):
            close(x, y, tol, what)
        return
    if b is None:  # JSON null: an infinite sigma
        assert math.isinf(a), f"{what}: {a} vs null"
        return
    assert abs(a - b) <= tol, f"{what}: {a} vs {b}"


def stamp(t):
    return t.secs + t.nsecs * 1e-9


def compare(out_bag, reference):
    """The node's windows and estimates against `fdv run`'s files; returns counts."""
    windows, estimates, predictions = [], [], []
    topics = {"/fdv/detections": windows, "/fdv/estimates": estimates, "/fdv/collision": predictions}
    with rosbag.Bag(out_bag) as bag:
        for topic, m, _ in bag.read_messages(topics=list(topics)):
            topics[topic].append(m)
    ref_windows = jsonl(os.path.join(reference, "detections.jsonl"))
    ref_estimates = jsonl(os.path.join(reference, "trajectories.jsonl"))
    ref_predictions = jsonl(os.path.join(reference, "predictions.jsonl"))
    assert len(windows) == len(ref_windows), f"{len(windows)} windows published, fdv run has {len(ref_windows)}"
    t_tol = 1e-6  # the rows' seconds as ROS time: exact to the ns rounding
    for i, (m, r) in enumerate(zip(windows, ref_windows)):
        what = f"window {i}"
        close(stamp(m.t_start), r["t_start"], t_tol, what + " t_start")
        close(stamp(m.t_end), r["t_end"], t_tol, what + " t_end")
        assert m.status == r["status"], f"{what}: status {m.status} vs {r['status']}"
        assert m.events == r["events"], f"{what}: events {m.events} vs {r['events']}"
        assert len(m.detections) == len(r["detections"]), f"{what}: detections differ"
        for d, rd in zip(m.detections, r["detections"]):
            close(list(d.box), rd["box"], 1e-9, what + " box")
            close(list(d.center), rd["center"], 1e-9, what + " center")
            assert d.track == rd["track"], what + " track"
    assert len(estimates) == len(ref_estimates), f"{len(estimates)} estimates published, fdv run has {len(ref_estimates)}"
    for i, (m, r) in enumerate(zip(estimates, ref_estimates)):
        what = f"estimate {i} (track {r['track']}, {r['method']})"
        assert (m.track, m.method, m.usable) == (r["track"], r["method"], r["usable"]), what
        close(stamp(m.header.stamp), r["t"], t_tol, what + " t")
        close([m.p0.x, m.p0.y, m.p0.z], r["p0"], 1e-9, what + " p0")
        close([m.v0.x, m.v0.y, m.v0.z], r["v0"], 1e-9, what + " v0")
    assert len(predictions) == len(ref_predictions), \
        f"{len(predictions)} predictions published, fdv run has {len(ref_predictions)}"
    for i, (m, r) in enumerate(zip(predictions, ref_predictions)):
        what = f"prediction {i} (track {r['track']})"
        close(stamp(m.header.stamp), r["t"], t_tol, what + " t")
        close(m.miss_distance, r["miss_distance"], 1e-9, what + " miss_distance")
        if "miss_distance_sigma" in r:
            close(m.miss_distance_sigma, r["miss_distance_sigma"], 1e-9, what + " miss_distance_sigma")
        else:
            assert math.isnan(m.miss_distance_sigma), what + ": a sigma where fdv run has none"
    return len(windows), sum(len(m.detections) for m in windows), len(estimates), len(predictions)


def last_diagnostics(out_bag):
    values = None
    with rosbag.Bag(out_bag) as bag:
        for _, m, _ in bag.read_messages(topics=["/diagnostics"]):
            for s in m.status:
                if s.name == "fdv: perception":
                    values = {kv.key: kv.value for kv in s.values}
    return values


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("work")
    ap.add_argument("--events-as", default="event_array")
    ap.add_argument("--rate", type=float, default=0.25)
    ap.add_argument("--resolution", default="")
    a = ap.parse_args()
    fdv = os.path.join(a.build, "fdv")
    node = os.path.join(a.build, "fdv_ros_node")
    os.makedirs(a.work, exist_ok=True)
    work = tempfile.mkdtemp(dir=a.work)
    dataset, bag, reference = (os.path.join(work, n) for n in ("dataset", "input.bag", "reference"))
    simulate = [fdv, "simulate", "--scenario", SCENARIO[0], "--seed", SCENARIO[1], "--out", dataset]
    if a.resolution:
        simulate += ["--resolution", a.resolution]
    run(simulate, stdout=subprocess.DEVNULL)
    export = [fdv, "export", dataset, "--to", "ros1-bag", bag]
    if a.events_as != "event_array":
        export += ["--events-as", a.events_as, "--encoding", "mono"]
    run(export, stdout=subprocess.DEVNULL)
    calibration = os.path.join(dataset, "calibration.yaml")
    run([fdv, "run", bag, "--calib", calibration, "--out", reference], stderr=subprocess.DEVNULL)
    with rosbag.Bag(bag) as b:
        counts = {t: info.message_count for t, info in b.get_type_and_topic_info().topics.items()}
        duration_s = b.get_end_time() - b.get_start_time()
    with open(os.path.join(reference, "summary.json")) as f:
        events = json.load(f)["counts"]["events_read"]

    port = free_port()
    env = dict(os.environ, ROS_MASTER_URI=f"http://127.0.0.1:{port}", ROS_IP="127.0.0.1",
               ROS_HOME=work, ROS_LOG_DIR=os.path.join(work, "log"))
    procs = Processes(env, work)
    try:
        procs.start("roscore", ["roscore", "-p", str(port)])
        import rosgraph
        master = rosgraph.Master("/node_replay_test", master_uri=env["ROS_MASTER_URI"])
        def master_up():
            try:
                master.getPid()
                return True
            except Exception:
                return False
        wait_until(master_up, "roscore")
        procs.start("node", [node, "__name:=fdv", "_calibration:=" + calibration,
                             "_wait_for_depth:=" + ("true" if a.rate < 1 else "false"),
                             "_idle_finish_s:=1.5"])
        out_bag = os.path.join(work, "output.bag")
        recorder = procs.start("record", ["rosbag", "record", "-O", out_bag, "/fdv/detections", "/fdv/estimates",
                                          "/fdv/tracks", "/fdv/collision", "/fdv/dodge", "/diagnostics"])
        def subscribed():
            _, subscribers, _ = master.getSystemState()
            subs = {t: n for t, n in subscribers}
            return all(t in subs for t in counts) and "/fdv/detections" in subs
        wait_until(subscribed, "the node's and the recorder's subscriptions")
        time.sleep(1.0)  # connections made after registration
        started = time.monotonic()
        # The player advertises its topics when it starts; without waiting for each topic's
        # subscriber to connect, its first messages can go out before the node's connection is made.
        # Its outgoing queue is as deep as the node's, so a busy machine delays messages, not drops them.
        run(["rosbag", "play", "-q", "--wait-for-subscribers", "--queue=10000", "-r", str(a.rate), bag],
            env=env, stdout=subprocess.DEVNULL)
        played_s = time.monotonic() - started
        print(f"played {events} events of {duration_s:.2f} s at rate {a.rate} ({played_s:.2f} s wall): "
              f"{events * a.rate / duration_s / 1e6:.2f} M events/s in", flush=True)
        # The node closes the last window after idle_finish_s; then one more diagnostics tick.
        time.sleep(1.5 + 2.5)
        procs.stop(recorder)
        # The rosbag wrapper exits at once; its recorder renames output.bag.active when closed.
        wait_until(lambda: os.path.exists(out_bag) and not os.path.exists(out_bag + ".active"), "the recorded bag")
        diag = last_diagnostics(out_bag)
        assert diag, "no diagnostics recorded"
        for topic, n in counts.items():
            stream = {"/dvs/events": "events", "/mavros/imu/data": "imu",
                      "/camera/depth/image_rect_raw": "depth", "/mavros/local_position/odom": "odometry"}[topic]
            received = int(diag[stream + ".messages"])
            assert received == n, f"{topic}: {received} of {n} messages received"
            assert int(diag[stream + ".dropped"]) == 0, f"{topic}: {diag[stream + '.dropped']} dropped"
        print("received every message:", counts)
        print("latency ms:", {k: v for k, v in diag.items() if k.startswith("latency_ms")})
        if a.rate < 1:
            windows, detections, estimates, predictions = compare(out_bag, reference)
            print(f"equal to fdv run: {windows} windows, {detections} detections, {estimates} estimates, "
                  f"{predictions} predictions")
    except Exception:
        for name, _ in procs.started:
            print(f"--- {name} log (tail)\n" + procs.log(name)[-3000:], file=sys.stderr)
        raise
    finally:
        procs.stop_all()


if __name__ == "__main__":
    main()
