"""Speed of the fdv Python package against the C++ it wraps (docs/BENCHMARKS.md "Python").

    PYTHONPATH=build/python /usr/bin/python3 bench/python_bench.py [--repeat 5] [--dataset DIR]

1. Reading: events/s of `for events in fdv.open(path)` (numpy arrays, the one conversion from the
   reader's buffer) against a C++ pass of the same reader over the same file in the same process,
   with no conversion (`Recording.info`: `fdv info`'s summarize_recording, which reads every chunk
   and counts).
2. Pipeline: wall time of fdv.Perception driven from Python (fed rec.merged(), the order
   `fdv run` feeds it, one push per IMU sample; or rec.chunks(), one push per stream and read),
   results as dicts, against `fdv run` on the same simulated dataset (a process, writing its
   files) and fdv.run (the same C++ replay called in-process, no files).
Best of --repeat runs each in CPU time (user + system, children included), files in the page
cache after the first.
"""
import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import fdv

REPO = Path(__file__).resolve().parents[1]
FDV_CLI = os.environ.get("FDV_CLI", str(REPO / "build" / "fdv"))
REAL = REPO.parent / "shared" / "data" / "real"


def cpu_seconds():
    """CPU time of this process and its finished children: on a shared machine it moves far less
    with the load than wall time does (everything measured here runs on one thread)."""
    own = time.process_time()
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own + children.ru_utime + children.ru_stime


def best(fn, repeat):
    times = []
    for _ in range(repeat):
        t0 = cpu_seconds()
        fn()
        times.append(cpu_seconds() - t0)
    return min(times)


def read_all(path):
    return sum(len(e) for e in fdv.open(path))


def perception_from_python(dataset):
    rec = fdv.open(dataset, time_unit="ns")
    p = fdv.Perception(rec.calibration, fdv.PerceptionOptions(), time_unit="ns")
    push = {"events": p.push_events, "imu": p.push_imu, "odometry": p.push_odometry}
    for kind, data in rec.merged():
        if kind == "depth":
            p.push_depth(data[1], data[0])
        elif kind in push:
            push[kind](data)
    return p.finish()


def perception_by_chunks(dataset):
    """Each read's IMU, odometry and depth, then its events: fewer, larger pushes than merged()."""
    rec = fdv.open(dataset, time_unit="ns")
    p = fdv.Perception(rec.calibration, fdv.PerceptionOptions(), time_unit="ns")
    for c in rec.chunks():
        p.push_imu(c["imu"])
        p.push_odometry(c["odometry"])
        for t, depth in c["depth"]:
            p.push_depth(depth, t)
        p.push_events(c["events"])
    return p.finish()


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--dataset", help="a simulated dataset (default: scene2_ball seed 3, 1 s, simulated here)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        dataset = args.dataset
        if not dataset:
            dataset = os.path.join(tmp, "scene2_ball")
            fdv.simulate("scene2_ball", seed=3, out=dataset, duration=1.0)
        inputs = [dataset] + [str(p) for p in sorted(REAL.glob("*")) if p.suffix in (".aedat4", ".raw", ".db3")]
        print(f"# reading: best of {args.repeat}; Python = numpy arrays by chunk, C++ = the reader alone (.info)")
        print(f"{'input':40s} {'events':>10s} {'Python Mev/s':>13s} {'C++ Mev/s':>10s} {'Py/C++':>7s}")
        for path in inputs:
            n = read_all(path)
            t_py = best(lambda: read_all(path), args.repeat)
            t_cpp = best(lambda: fdv.open(path).info, args.repeat)
            print(f"{Path(path).name:40s} {n:10d} {n / t_py / 1e6:13.1f} {n / t_cpp / 1e6:10.1f} {t_cpp / t_py * 100:5.0f} %")

        out = os.path.join(tmp, "run")
        t_cli = best(lambda: subprocess.run([FDV_CLI, "run", dataset, "--out", out], check=True, capture_output=True),
                     args.repeat)
        t_py = best(lambda: perception_from_python(dataset), args.repeat)
        t_chunks = best(lambda: perception_by_chunks(dataset), args.repeat)
        t_run = best(lambda: fdv.run(dataset), args.repeat)
        windows = fdv.run(dataset).counts["windows"]
        print(f"\n# pipeline on {Path(dataset).name} ({windows} windows): best of {args.repeat}")
        print(f"fdv run (C++ program)            {t_cli * 1e3:8.0f} ms")
        print(f"fdv.run (C++ replay in Python)   {t_run * 1e3:8.0f} ms  ({(t_run / t_cli - 1) * 100:+.0f} % vs fdv run)")
        for name, t in [("merged()", t_py), ("chunks()", t_chunks)]:
            print(f"fdv.Perception from Python, {name} {t * 1e3:6.0f} ms  ({(t / t_cli - 1) * 100:+.0f} % vs fdv run, "
                  f"{(t / t_run - 1) * 100:+.0f} % vs fdv.run)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
