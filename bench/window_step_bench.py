#!/usr/bin/python3
"""What a shorter window step costs: the pipeline's CPU per second of data with windows every
`step_ms` against consecutive windows, on the given recordings or dataset folders.

    /usr/bin/python3 bench/window_step_bench.py [--fdv build/fdv] [--steps 25,5] [--rounds 3] INPUT...

Each input is run with `fdv run INPUT --threads 1 --config STEP.yaml` for every step in turn,
`--rounds` times alternating, pinned to one core with `taskset -c 1` when taskset exists. Per run:
the sum of `timing.csv`'s window_total (the time from each window's end until all its results
exist) over the data's duration (the first to the last window's start, plus one step), and the
process's user + system CPU over the same duration (reading, depth registration and start-up
included). Prints the median over the rounds, and each step's ratio to the first step's.
Extra YAML for every run (e.g. `window_ms: 25`) goes in --config.
"""
import argparse
import csv
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path


def run_once(fdv, source, step_ms, extra_yaml, work):
    config = work / f"step{step_ms}.yaml"
    config.write_text(f"step_ms: {step_ms}\n{extra_yaml}")
    out = work / f"run{step_ms}"
    shutil.rmtree(out, ignore_errors=True)
    command = [fdv, "run", str(source), "--out", str(out), "--threads", "1", "--config", str(config)]
    if shutil.which("taskset"):
        command = ["taskset", "-c", "1", *command]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    result = subprocess.run(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if result.returncode != 0:
        sys.exit(f"{' '.join(command)} failed ({result.returncode}): {result.stderr.strip()[-400:]}")
    rows = list(csv.DictReader(open(out / "timing.csv")))
    if len(rows) < 2:
        sys.exit(f"{source}: fewer than two windows")
    starts = [float(r["t_start"]) for r in rows]  # s
    seconds = max(starts) - min(starts) + step_ms / 1e3
    window_ms = sum(float(r["window_total"]) for r in rows)
    cpu_ms = ((after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)) * 1e3
    return len(rows), window_ms / seconds, cpu_ms / seconds


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("inputs", nargs="+")
    parser.add_argument("--fdv", default="build/fdv")
    parser.add_argument("--steps", default="25,5", help="step_ms values, the first the reference")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--config", default="", help="extra YAML lines for every run")
    a = parser.parse_args()
    steps = [float(s) for s in a.steps.split(",")]
    extra = Path(a.config).read_text() if a.config else ""
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        print("| input | step [ms] | windows | window_total per s of data [ms] | process CPU per s of data [ms] | ratio (window_total) | ratio (process) |")
        print("|---|---|---|---|---|---|---|")
        for source in a.inputs:
            results = {s: [] for s in steps}
            for _ in range(a.rounds):
                for s in steps:
                    results[s].append(run_once(a.fdv, source, s, extra, work))
            base = None
            for s in steps:
                windows = results[s][0][0]
                pipeline = statistics.median(r[1] for r in results[s])
                process = statistics.median(r[2] for r in results[s])
                base = base or (pipeline, process)
                print(f"| {os.path.basename(os.path.normpath(source))} | {s:g} | {windows} | {pipeline:.1f} | {process:.0f} "
                      f"| {pipeline / base[0]:.2f} | {process / base[1]:.2f} |", flush=True)


if __name__ == "__main__":
    main()
