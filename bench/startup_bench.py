#!/usr/bin/python3
"""What starting `fdv` costs: wall time and peak memory of `fdv --version` (or the arguments
given), and the shared libraries it loads, counted as `ldd FDV | wc -l` counts them.

    /usr/bin/python3 bench/startup_bench.py [--fdv build/fdv] [--runs 50] [-- ARGS...]

Prints the median and the fastest of the runs (the page cache is warm after the first), the
largest peak RSS, and the library count (ldd's lines: vdso and the loader included).
"""
import argparse
import resource
import statistics
import subprocess
import time


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--fdv", default="build/fdv")
    parser.add_argument("--runs", type=int, default=50)
    parser.add_argument("args", nargs="*", default=["--version"])
    a = parser.parse_args()
    walls = []
    for _ in range(a.runs):
        start = time.perf_counter()
        subprocess.run([a.fdv, *a.args], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=False)
        walls.append((time.perf_counter() - start) * 1000)
    peak_mb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    libraries = len(subprocess.run(["ldd", a.fdv], capture_output=True, text=True, check=True).stdout.splitlines())
    print(f"{a.fdv} {' '.join(a.args)}: median {statistics.median(walls):.1f} ms, fastest {min(walls):.1f} ms "
          f"over {a.runs} runs; peak RSS {peak_mb:.0f} MB; {libraries} shared libraries (ldd)")


if __name__ == "__main__":
    main()
