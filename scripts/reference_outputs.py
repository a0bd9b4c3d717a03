#!/usr/bin/python3
"""Proves that a change keeps the pipeline's results: runs `fdv run` on the training datasets and
the real recordings, and compares what it wrote with a stored run, field by field.

    /usr/bin/python3 scripts/reference_outputs.py compare   # exit 1 and the differences if any
    /usr/bin/python3 scripts/reference_outputs.py record    # store this build's outputs instead

Runs: the training seeds 1-4 of fast_forward, swing, hover_headon and
scene2_ball, simulated by the same build (a change to the simulator shows as a change of the
outputs), and every recording in ../shared/data/real (the DAVIS346 throw also with its
calibration). Compared: detections.jsonl, depth.jsonl, trajectories.jsonl, predictions.jsonl, dodge.jsonl
line by line, and summary.json without its timing (`timing_ms`) and input path; not timing.csv
(wall-clock). Numbers must be equal to the bit: the pipeline is deterministic for a given build and
thread count.

The stored run lives in tests/reference_outputs/RUN/; a commit that changes results on purpose
records it anew in a commit of its own, with the differences explained. Work files go to
out/reference/ (datasets, runs). Run from anywhere; paths are relative to the repository root so
that stored files do not depend on the clone's location.
"""
import argparse
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
REAL = Path("..") / "shared" / "data" / "real"
STORED = Path("tests") / "reference_outputs"
JSONL = ["detections.jsonl", "depth.jsonl", "trajectories.jsonl", "predictions.jsonl", "dodge.jsonl"]
SUMMARY_EXCLUDED = {"timing_ms", "input"}
TRAINING_SCENARIOS = ["fast_forward", "swing", "hover_headon", "scene2_ball"]
TRAINING_SEEDS = [1, 2, 3, 4]
DAVIS346_CALIBRATION = REAL / "davis346_00000133_calibration.xml"


def runs(work):
    """(name, input, extra fdv run arguments) of every run; simulates the training datasets."""
    out = []
    for scenario in TRAINING_SCENARIOS:
        for seed in TRAINING_SEEDS:
            out.append((f"{scenario}_s{seed}", work / "datasets" / f"{scenario}_s{seed}", []))
    for recording in sorted(REAL.iterdir()):
        if recording.suffix in (".aedat4", ".raw", ".db3"):
            out.append((recording.stem, recording, []))
    out.append(("davis346_ball_throw_person_calibrated", REAL / "davis346_ball_throw_person.aedat4",
                ["--calib", str(DAVIS346_CALIBRATION)]))
    return out


def simulate(fdv, work):
    for scenario in TRAINING_SCENARIOS:
        for seed in TRAINING_SEEDS:
            dataset = work / "datasets" / f"{scenario}_s{seed}"
            shutil.rmtree(dataset, ignore_errors=True)
            subprocess.run([fdv, "simulate", "--scenario", scenario, "--seed", str(seed), "--out", str(dataset)],
                           check=True, capture_output=True)


def run_all(fdv, work):
    """Runs the pipeline on every input; returns {run name: output folder}."""
    simulate(fdv, work)
    folders = {}
    for name, source, extra in runs(work):
        out = work / "runs" / name
        shutil.rmtree(out, ignore_errors=True)
        done = subprocess.run([fdv, "run", str(source), *extra, "--out", str(out)], capture_output=True, text=True)
        if done.returncode != 0:
            sys.exit(f"fdv run {source} failed:\n{done.stderr}")
        folders[name] = out
        print(f"ran {name}", flush=True)
    return folders


def summary_without_timing(path):
    summary = json.loads(path.read_text())
    return {k: v for k, v in summary.items() if k not in SUMMARY_EXCLUDED}


def differences(expected, actual, where, out, limit=5):
    """Appends 'where: expected X, got Y' for each differing field (at most `limit`)."""
    if len(out) >= limit:
        return
    if isinstance(expected, dict) and isinstance(actual, dict):
        for key in sorted(set(expected) | set(actual)):
            if key not in actual:
                out.append(f"{where}.{key}: missing")
            elif key not in expected:
                out.append(f"{where}.{key}: new field")
            else:
                differences(expected[key], actual[key], f"{where}.{key}", out, limit)
    elif isinstance(expected, list) and isinstance(actual, list) and len(expected) == len(actual):
        for i, (e, a) in enumerate(zip(expected, actual)):
            differences(e, a, f"{where}[{i}]", out, limit)
    elif expected != actual or type(expected) is not type(actual):
        out.append(f"{where}: expected {json.dumps(expected)[:120]}, got {json.dumps(actual)[:120]}")


def compare_run(stored, produced):
    """Differences between a stored run folder and a produced one."""
    found = []
    for name in JSONL:
        expected = (stored / name).read_text().splitlines() if (stored / name).exists() else []
        actual = (produced / name).read_text().splitlines() if (produced / name).exists() else []
        if len(expected) != len(actual):
            found.append(f"{name}: {len(expected)} lines stored, {len(actual)} now")
        for i, (e, a) in enumerate(zip(expected, actual)):
            differences(json.loads(e), json.loads(a), f"{name}:{i + 1}", found)
    differences(json.loads((stored / "summary.json").read_text()), summary_without_timing(produced / "summary.json"),
                "summary.json", found)
    return found


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("action", choices=["compare", "record"])
    parser.add_argument("--fdv", default="build/fdv", help="the fdv binary (default build/fdv)")
    parser.add_argument("--work", default="out/reference", help="datasets and runs (default out/reference)")
    args = parser.parse_args()
    os.chdir(ROOT)
    fdv, work = str(Path(args.fdv).resolve()), Path(args.work)
    folders = run_all(fdv, work)
    if args.action == "record":
        shutil.rmtree(STORED, ignore_errors=True)
        for name, produced in folders.items():
            (STORED / name).mkdir(parents=True)
            for file in JSONL:
                if (produced / file).exists():
                    shutil.copy(produced / file, STORED / name / file)
            (STORED / name / "summary.json").write_text(
                json.dumps(summary_without_timing(produced / "summary.json"), indent=1, sort_keys=True) + "\n")
        print(f"recorded {len(folders)} runs into {STORED}")
        return
    differing = 0
    for name, produced in folders.items():
        if not (STORED / name).exists():
            print(f"{name}: no stored run")
            differing += 1
            continue
        found = compare_run(STORED / name, produced)
        if found:
            differing += 1
            print(f"{name}: differs\n  " + "\n  ".join(found))
    print(f"{len(folders) - differing} passed, {differing} failed")
    sys.exit(1 if differing else 0)


if __name__ == "__main__":
    main()
