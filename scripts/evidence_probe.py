#!/usr/bin/env python3
"""Would evidence summed over windows show a far ball before the detector does?

For one simulated dataset and its `fdv eval`-ed run folder, counts each window's raw events per
C x C cell and scores every cell by z = (S_N - N m) / sqrt(N m + 1): S_N its count over the last
N windows, m its own exponentially averaged count per window before them (weight 0.05). Prints, per
window, the ball's best z (the 3 x 3 cells around its true centre), how many cells of the image
score higher, and the image's top z; in windows without the ball, the top z and the cells over 20.
A design probe for the track-before-detect source (docs/DETECTION.md, "Known limitations"); it
does not compensate ego-motion.

    /usr/bin/python3 scripts/evidence_probe.py DATASET RUN [--windows 4] [--cell 8]
"""
import argparse
import csv
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), '..', 'build', 'python'))
import fdv  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('dataset')
    ap.add_argument('run', help='results folder of `fdv run`, with `fdv eval`\'s detection_pairs.csv')
    ap.add_argument('--windows', type=int, default=4)
    ap.add_argument('--cell', type=int, default=8)
    ap.add_argument('--window-ms', type=float, default=25)
    a = ap.parse_args()
    rec = fdv.open(a.dataset)
    ev = np.concatenate(list(rec.events()))
    per_s = {'us': 1e6, 'ns': 1e9}[rec.time_unit] if isinstance(rec.time_unit, str) else 1e6
    win = int(a.window_ms * 1e-3 * per_s)
    t0 = int(ev['t'][0])
    k = ((ev['t'] - t0) // win).astype(int)
    C, N = a.cell, a.windows
    counts = np.zeros((k.max() + 1, (rec.height + C - 1) // C, (rec.width + C - 1) // C))
    np.add.at(counts, (k, ev['y'] // C, ev['x'] // C), 1)
    pairs = {round(float(p['t_end_s']), 3): p
             for p in csv.DictReader(open(os.path.join(a.run, 'detection_pairs.csv')))}
    mean = None
    for i in range(counts.shape[0]):
        if i >= N and mean is not None:
            z = (counts[i - N + 1:i + 1].sum(0) - N * mean) / np.sqrt(N * mean + 1)
            t_end = round((t0 + (i + 1) * win) / per_s, 3)
            p = pairs.get(t_end)
            if p and p['u_min']:
                cu = int((float(p['u_min']) + float(p['u_max'])) / 2 // C)
                cv = int((float(p['v_min']) + float(p['v_max'])) / 2 // C)
                zb = z[max(cv - 1, 0):cv + 2, max(cu - 1, 0):cu + 2].max()
                print(f"{t_end:.3f} ball {float(p['size_px']):5.1f} px found {p['found']}: z {zb:6.1f}, "
                      f"{int((z > zb).sum()):4d} cells higher, top z {z.max():6.1f}")
            else:
                print(f"{t_end:.3f} no ball in view: top z {z.max():6.1f}, {int((z > 20).sum())} cells over 20")
        if i >= N:
            old = counts[i - N]
            mean = old.copy() if mean is None else 0.95 * mean + 0.05 * old


if __name__ == '__main__':
    main()
