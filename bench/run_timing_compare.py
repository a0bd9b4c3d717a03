"""Front-end time of two `fdv` builds on the same recordings (docs/BENCHMARKS.md, "Several objects,
any size, border cuts").

    /usr/bin/python3 bench/run_timing_compare.py BEFORE_FDV AFTER_FDV DATASET... [--rounds 4] [--threads N] [--stage NAME]

Runs `fdv run` of each build on every dataset, alternating the builds round by round so that both
see the same machine load. The front end of a run is the median of `compensation` plus the median
of `detection_total` from its summary.json's `timing_ms` (so a build that predates timing.csv can
be compared). Per dataset, each build's figure is the median over its rounds; the report gives
the after / before ratio per dataset and the median ratio. `--stage NAME` compares one stage's median
instead (a key of `timing_ms`, e.g. `evidence`). Standard library only.
"""
import argparse
import json
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path


def front_end_ms(summary_path, stage=None):
    try:
        timing = json.loads(Path(summary_path).read_text())["timing_ms"]
        if stage:
            return timing[stage]["median"]
        return timing["compensation"]["median"] + timing["detection_total"]["median"]
    except (OSError, ValueError, KeyError, TypeError) as e:
        wanted = stage or "compensation / detection_total"
        sys.exit(f"{summary_path}: no timing_ms.{wanted} median ({e!r})")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("before", help="the fdv binary measured first in each round")
    parser.add_argument("after", help="the fdv binary it is compared with")
    parser.add_argument("datasets", nargs="+", help="recordings or dataset folders")
    parser.add_argument("--rounds", type=int, default=4)
    parser.add_argument("--threads", type=int, help="passed to `fdv run` (its default otherwise)")
    parser.add_argument("--stage", help="compare this timing_ms stage's median instead of the front end")
    args = parser.parse_args()
    if args.rounds < 1:
        parser.error("--rounds must be at least 1")

    figures = {build: {d: [] for d in args.datasets} for build in ("before", "after")}
    with tempfile.TemporaryDirectory() as work:
        for round_index in range(args.rounds):
            for build, binary in (("before", args.before), ("after", args.after)):
                for i, dataset in enumerate(args.datasets):
                    out = Path(work) / f"{build}_{round_index}_{i}"
                    try:
                        threads = ["--threads", str(args.threads)] if args.threads else []
                        run = subprocess.run([binary, "run", dataset, "--out", str(out), *threads],
                                             capture_output=True, text=True)
                    except OSError as e:
                        sys.exit(f"{binary}: cannot run it ({e.strerror})")
                    if run.returncode != 0:
                        sys.exit(f"{binary} run {dataset} failed ({run.returncode}): {run.stderr.strip()[-400:]}")
                    figures[build][dataset].append(front_end_ms(out / "summary.json", args.stage))

    ratios = []
    print(f"{'dataset':<50} {'before ms':>10} {'after ms':>10} {'ratio':>7}")
    for dataset in args.datasets:
        before = statistics.median(figures["before"][dataset])
        after = statistics.median(figures["after"][dataset])
        ratios.append(after / before)
        print(f"{dataset:<50} {before:>10.3f} {after:>10.3f} {after / before:>7.2f}")
    print(f"median ratio {statistics.median(ratios):.2f} over {len(ratios)} datasets, {args.rounds} rounds")


if __name__ == "__main__":
    main()
