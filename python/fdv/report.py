"""Plots of a `fdv run` results folder, in one HTML page.

    python3 -m fdv.report RESULTS_DIR [--truth DATASET] [--out DIR]

Writes DIR/report.html (DIR defaults to RESULTS_DIR/report) and its PNGs: the detection timeline
(u, v per track, the true ball's projection beside it with --truth), each track's 3D trajectory in
top and side views against the truth, the prediction error at the true closest approach against
the time since the track's first detection, the dodge (with --truth and decisions in dodge.jsonl:
the vehicle's path with its safety sphere and the ball's, the predicted passage at each decision,
the manoeuvre, the closest approach with and without it), a latency histogram of each stage
(timing.csv; older results folders without it: median, p99 and max bars from summary.json), and a
strip of window images (when the run had --visualize). The files are read as the results schema writes them
(docs/FORMATS.md "fdv run outputs").
"""
import argparse
import html
import json
import os
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

TRACK_COLORS = plt.rcParams["axes.prop_cycle"].by_key()["color"]


class ReportError(ValueError):
    """An input the report cannot use; the message names the file and the reason."""


def read_jsonl(path):
    if not path.exists():
        return []
    rows = []
    with open(path) as f:
        for number, line in enumerate(f, 1):
            if line.strip():
                try:
                    rows.append(json.loads(line))
                except json.JSONDecodeError as e:
                    raise ReportError(f"{path}: line {number}: {e.msg}") from None
    return rows


def read_summary(results):
    """RESULTS/summary.json, which a run writes last: without it the folder is not a finished run."""
    path = results / "summary.json"
    if not path.is_file():
        raise ReportError(f"{path}: missing: {results} is not a finished `fdv run` results folder")
    try:
        return json.loads(path.read_text())
    except json.JSONDecodeError as e:
        raise ReportError(f"{path}: line {e.lineno}: {e.msg} (a truncated or foreign file)") from None


def check_truth_matches(summary, truth, truth_dir):
    """The truth must be of the scene the results were run on: same camera size, and the same
    dataset.yaml when the run's input is still there."""
    width, height = summary.get("resolution", [truth.calibration.width, truth.calibration.height])
    if (width, height) != (truth.calibration.width, truth.calibration.height):
        raise ReportError(f"{truth_dir}: its camera is {truth.calibration.width}x{truth.calibration.height}, "
                          f"the results' {width}x{height}: --truth is of another scene")
    ran_on = Path(summary.get("input", "")) / "dataset.yaml"
    given = Path(truth_dir) / "dataset.yaml"
    if ran_on.is_file() and given.is_file() and ran_on.read_bytes() != given.read_bytes():
        raise ReportError(f"{truth_dir}: not the dataset the results were run on ({ran_on.parent}): "
                          "--truth is of another scene")


def read_timing(results):
    """RESULTS/timing.csv: a structured array, one row per window, fields `window`, `t_start` [s] and
    each stage [ms] (NaN where the stage did not run); None when absent (older results)."""
    path = Path(results) / "timing.csv"
    if not path.exists() or len(path.read_text().splitlines()) < 2:  # no window: nothing to plot
        return None
    return np.atleast_1d(np.genfromtxt(path, delimiter=",", names=True, dtype=float))


class Truth:
    """A simulated dataset's truth (fdv.load_truth), times in seconds."""

    def __init__(self, dataset):
        import fdv
        t = fdv.load_truth(os.fspath(dataset), time_unit="ns")
        self.calibration = t["calibration"]
        self.body = t["body"]
        self.body_t = self.body["t"] * 1e-9
        self.objects = t["objects"]
        self.balls = t["balls"]
        # A flown simulation (`fdv simulate --fly`, the closed loop) keeps the path without its manoeuvre.
        unflown = Path(dataset) / "truth" / "body_unflown.csv"
        self.body_unflown = np.loadtxt(unflown, delimiter=",", comments="#", ndmin=2) if unflown.exists() else None

    def ball(self, ball_id):
        o = self.objects[self.objects["id"] == ball_id]
        return o["t"] * 1e-9, np.stack([o["px"], o["py"], o["pz"]], axis=1)

    def position_at(self, ball_id, t_s):
        """Ball position at t_s, linear between the 1 kHz samples."""
        t, p = self.ball(ball_id)
        return np.array([np.interp(t_s, t, p[:, k]) for k in range(3)]).T

    def project(self, ball_id):
        """Times [s] and raw pixels of ball_id's centre in the event camera."""
        t, p_W = self.ball(ball_id)
        b = self.body
        i = np.clip(np.searchsorted(self.body_t, t), 0, len(b) - 1)  # truth at 1 kHz: nearest sample
        R_W_B = quaternion_matrix(b["qx"][i], b["qy"][i], b["qz"][i], b["qw"][i])
        p_B = np.einsum("nji,nj->ni", R_W_B, p_W - np.stack([b["px"][i], b["py"][i], b["pz"][i]], axis=1))
        T_B_E = self.calibration.T_B_E
        p_E = (p_B - T_B_E[:3, 3]) @ T_B_E[:3, :3]
        return t, self.calibration.project(p_E)

    def nearest_ball(self, points_W, times_s):
        """The ball whose truth passes nearest the estimated points; None in a scene without one."""
        if not self.balls:
            return None
        best = min(self.balls, key=lambda b: np.nanmean(np.linalg.norm(self.position_at(b, times_s) - points_W, axis=1)))
        return best


def quaternion_matrix(x, y, z, w):
    """Rotation matrices (N, 3, 3) of unit quaternions."""
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], axis=-1),
        np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], axis=-1),
        np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], axis=-1),
    ], axis=-2)


def trajectory_at(row, t_s):
    """Position of a trajectories.jsonl solve at t_s: p0 + v0 τ + ½ g τ²."""
    tau = np.asarray(t_s, dtype=float)[..., None] - row["t0"]
    return np.asarray(row["p0"]) + np.asarray(row["v0"]) * tau + 0.5 * np.asarray(row["gravity"]) * tau * tau


def detections_by_track(windows):
    tracks = {}
    for w in windows:
        for d in w["detections"]:
            tracks.setdefault(d.get("track", -1), []).append((d["t"], d["center"][0], d["center"][1]))
    return {k: np.array(v) for k, v in sorted(tracks.items())}


def save(fig, out, name):
    fig.tight_layout()
    fig.savefig(out / name, dpi=90)
    plt.close(fig)
    return name


def plot_timeline(windows, truth, out):
    tracks = detections_by_track(windows)
    fig, axes = plt.subplots(2, 1, figsize=(10, 6), sharex=True)
    for k, (track, d) in enumerate(tracks.items()):
        label = f"track {track}" if track >= 0 else "unassigned"
        style = dict(color=TRACK_COLORS[k % len(TRACK_COLORS)], s=10, label=label)
        axes[0].scatter(d[:, 0], d[:, 1], **style)
        axes[1].scatter(d[:, 0], d[:, 2], **style)
    if truth is not None:
        for ball in truth.balls:
            t, px = truth.project(ball)
            t0 = windows[0]["t_start"] if windows else t[0]
            t1 = windows[-1]["t_end"] if windows else t[-1]
            inside = (t >= t0) & (t <= t1) & (px[:, 0] >= 0) & (px[:, 0] < truth.calibration.width) \
                & (px[:, 1] >= 0) & (px[:, 1] < truth.calibration.height)
            tt, pp = np.where(inside, t, np.nan), np.where(inside[:, None], px, np.nan)
            axes[0].plot(tt, pp[:, 0], "k-", lw=1, label=f"truth, ball {ball}")
            axes[1].plot(tt, pp[:, 1], "k-", lw=1)
    axes[0].set_ylabel("u [px]")
    axes[1].set_ylabel("v [px]")
    axes[1].set_xlabel("t [s]")
    axes[1].invert_yaxis()
    if tracks or truth is not None:
        axes[0].legend(loc="best", fontsize=8)
    axes[0].set_title("Detections: image position of each track's detections (raw pixels)")
    return save(fig, out, "timeline.png")


def final_usable_fusion(trajectories):
    final = {}
    for r in trajectories:
        if r["method"] == "fusion" and r["usable"]:
            final[r["track"]] = r
    return final


def plot_trajectories(results, trajectories, truth, out):
    names = []
    for track, row in final_usable_fusion(trajectories).items():
        t = np.linspace(row["t_first"], row["t_last"], 50)
        p = trajectory_at(row, t)
        fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
        # The side view looks across the flight: along the horizontal axis it moves most on.
        along = 0 if abs(p[-1, 0] - p[0, 0]) >= abs(p[-1, 1] - p[0, 1]) else 1
        views = [(0, 1, "top view (x, y)"), (along, 2, f"side view ({'xy'[along]}, z)")]
        for ax, (i, j, view) in zip(axes, views):
            ax.plot(p[:, i], p[:, j], "-", color="C0", lw=2, label="fusion estimate (observed interval)")
            ax.plot(p[0, i], p[0, j], "o", color="C0")
            ball = truth.nearest_ball(p, t) if truth is not None else None
            if ball is not None:
                tb, pb = truth.ball(ball)
                in_flight = (tb >= t[0] - 0.1) & (tb <= t[-1] + 0.3)
                ax.plot(pb[in_flight, i], pb[in_flight, j], "k--", lw=1, label=f"truth, ball {ball}")
                ax.plot(*truth.position_at(ball, t[0])[[i, j]], "ko", ms=4)
            ax.set_xlabel("xyz"[i] + " [m]")
            ax.set_ylabel("xyz"[j] + " [m]")
            ax.set_title(f"track {track}: {view}")
            ax.set_aspect("equal", adjustable="datalim")
            ax.grid(alpha=0.3)
            ax.legend(fontsize=8)
        names.append(save(fig, out, f"trajectory_track_{track}.png"))
    return names


def plot_prediction_error(windows, trajectories, predictions, truth, out):
    first_seen = {}
    for w in windows:
        for d in w["detections"]:
            if d.get("track", -1) >= 0:
                first_seen.setdefault(d["track"], d["t"])
    fig, ax = plt.subplots(figsize=(10, 4))
    if truth is not None:
        for k, track in enumerate(sorted({r["track"] for r in trajectories})):
            # In time order: a solve on a late depth frame is written after later ones.
            rows = sorted((r for r in trajectories if r["track"] == track and r["method"] == "fusion" and r["usable"]),
                          key=lambda r: r["t"])
            if not rows or track not in first_seen:
                continue
            end = np.array(trajectory_at(rows[-1], [rows[-1]["t_last"]]))
            ball = truth.nearest_ball(end, [rows[-1]["t_last"]])
            if ball is None:
                continue
            t_ca = truth.balls[ball]["closest_approach_t"]
            if t_ca is None:
                continue
            t_ca *= 1e-9
            p_true = truth.position_at(ball, t_ca)
            err = [np.linalg.norm(trajectory_at(r, [t_ca])[0] - p_true) for r in rows]
            since = [r["t"] - first_seen[track] for r in rows]
            ax.plot(since, err, "o-", color=TRACK_COLORS[k % len(TRACK_COLORS)], ms=4,
                    label=f"track {track} vs ball {ball} (true closest approach at {t_ca:.3f} s)")
        ax.set_ylabel("position error at true closest approach [m]")
        ax.set_ylim(bottom=0)
        ax.set_title("Prediction error at the true closest approach (usable fusion solves)")
    else:
        for k, track in enumerate(sorted({p["track"] for p in predictions})):
            rows = sorted((p for p in predictions if p["track"] == track), key=lambda p: p["t"])
            t0 = first_seen.get(track, rows[0]["t"])
            color = TRACK_COLORS[k % len(TRACK_COLORS)]
            since = np.array([p["t"] - t0 for p in rows])
            miss = np.array([p["miss_distance"] for p in rows])
            ax.plot(since, miss, "o-", ms=4, color=color, label=f"track {track}")
            # ±1σ where the risk was assessed (predictions.jsonl's miss_distance_sigma)
            sigma = np.array([p.get("miss_distance_sigma", np.nan) for p in rows], dtype=float)
            if np.isfinite(sigma).any():
                ax.fill_between(since, miss - sigma, miss + sigma, where=np.isfinite(sigma), color=color, alpha=0.2)
        ax.set_ylabel("predicted miss distance [m] (band: ±1σ)")
        ax.set_title("Predicted miss distance (no --truth: the error needs the true path)")
    ax.set_xlabel("time since the track's first detection [s]")
    ax.grid(alpha=0.3)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=8)
    return save(fig, out, "prediction_error.png")


def closest_approach(t_s, body_W, ball_W):
    """Index of the least distance between two paths sampled at the same times, and that distance."""
    d = np.linalg.norm(ball_W - body_W, axis=1)
    i = int(np.argmin(d))
    return i, d[i]


def plot_dodge(results, dodge, predictions, truth, safety_radius_m, out):
    """The vehicle's path with and without the escape, the ball's, and what each decision saw."""
    acting = [d for d in dodge if d.get("maneuver")]
    if truth is None or not acting or not truth.balls:
        return None
    ball = min(truth.balls, key=lambda b: truth.balls[b].get("closest_approach_m") or np.inf)
    tb, pb = truth.ball(ball)
    b = truth.body
    body_t = truth.body_t
    body = np.stack([b["px"], b["py"], b["pz"]], axis=1)
    if truth.body_unflown is not None:  # flown: body.csv holds the escape
        flown, flown_label = body, "vehicle, flown"
        unflown = truth.body_unflown[:, 1:4]
    else:  # open loop: the escape is the set-points replayed on the path
        import fdv
        unflown = body
        flown, flown_label = body + fdv.maneuver_offset(os.fspath(results), body_t.tolist()), "vehicle, set-points replayed"
    ball_on_body = np.stack([np.interp(body_t, tb, pb[:, k]) for k in range(3)], axis=1)
    in_flight = (body_t >= tb[0]) & (body_t <= tb[-1])
    i_with, d_with = closest_approach(body_t[in_flight], flown[in_flight], ball_on_body[in_flight])
    i_without, d_without = closest_approach(body_t[in_flight], unflown[in_flight], ball_on_body[in_flight])
    t_in = body_t[in_flight]

    fig, axes = plt.subplots(1, 2, figsize=(12, 5))
    along = 0 if np.ptp(pb[:, 0]) >= np.ptp(pb[:, 1]) else 1  # the side view looks across the throw
    views = [(0, 1, "top view (x, y)"), (along, 2, f"side view ({'xy'[along]}, z)")]
    for ax, (i, j, view) in zip(axes, views):
        ax.plot(pb[:, i], pb[:, j], "k--", lw=1, label=f"ball {ball}, truth")
        ax.plot(unflown[:, i], unflown[:, j], "-", color="0.6", lw=2, label="vehicle, without the escape")
        ax.plot(flown[:, i], flown[:, j], "-", color="C0", lw=2, label=flown_label)
        for path, idx, dist, style, name in [(flown[in_flight], i_with, d_with, "C0", "with"),
                                             (unflown[in_flight], i_without, d_without, "0.6", "without")]:
            centre = path[idx]
            ax.add_patch(plt.Circle((centre[i], centre[j]), safety_radius_m, fill=False, color=style,
                                    ls="-" if name == "with" else ":"))
            ball_then = ball_on_body[in_flight][idx]
            ax.plot([centre[i], ball_then[i]], [centre[j], ball_then[j]], "-", color=style, lw=1,
                    label=f"closest approach {name} the escape: {dist:.2f} m at {t_in[idx]:.3f} s")
        for k, d in enumerate(acting):
            body_then = flown[np.clip(np.searchsorted(body_t, d["t"]), 0, len(body_t) - 1)]
            a = np.array(d["maneuver"]["acceleration_W"])
            ax.annotate("", xy=(body_then[i] + 0.05 * a[i], body_then[j] + 0.05 * a[j]), xytext=(body_then[i], body_then[j]),
                        arrowprops=dict(arrowstyle="->", color=f"C{1 + k % 8}"))
            same = [p for p in predictions if p["track"] == d["track"] and abs(p["t"] - d["t"]) < 1e-6]
            if same:
                p = same[-1]["object_W"]
                ax.plot(p[i], p[j], "x", color=f"C{1 + k % 8}", ms=8,
                        label=f"{d['action']} at {d['t']:.3f} s: predicted passage (x), set-point (arrow: a · 0.05 s²)")
        ax.set_xlabel("xyz"[i] + " [m]")
        ax.set_ylabel("xyz"[j] + " [m]")
        ax.set_title(view)
        ax.set_aspect("equal", adjustable="datalim")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7, loc="best")
    fig.suptitle(f"Dodge: {len(acting)} set-point decision(s); safety sphere {safety_radius_m} m")
    return save(fig, out, "dodge.png")


def plot_latency_histograms(timing, out):
    """One histogram per stage of every window's time (timing.csv), median and p99 marked; log-x
    bins when the slowest window took over 10 times the fastest (a window where the stage took 0 ms
    then falls outside them)."""
    stages = [name for name in timing.dtype.names[2:] if np.isfinite(timing[name]).any()]
    cols = 3
    rows = -(-len(stages) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(12, 2.6 * rows + 0.6), squeeze=False)
    for ax, stage in zip(axes.flat, stages):
        ms = timing[stage][np.isfinite(timing[stage])]
        positive = ms[ms > 0]
        wide = positive.size > 1 and positive.max() > 10 * positive.min()
        if wide:
            ax.hist(positive, bins=np.geomspace(positive.min(), positive.max(), 40), color="#1f5f99")
            ax.set_xscale("log")
        else:
            ax.hist(ms, bins=40, color="#1f5f99")
        for q, style, label in [(50, "-", "median"), (99, "--", "p99")]:
            ax.axvline(np.percentile(ms, q), color="#e8833a", linestyle=style, label=label)
        ax.set_title(f"{stage} (n={ms.size})", fontsize=10)
        ax.set_xlabel("ms")
        ax.grid(alpha=0.3)
    for ax in list(axes.flat)[len(stages):]:
        ax.set_axis_off()
    if stages:
        axes.flat[0].set_ylabel("windows")
        axes.flat[0].legend(fontsize=8)
    fig.suptitle("Latency per stage: wall-clock time of each window")
    return save(fig, out, "latency_histograms.png")


def plot_latency(summary, out):
    """Each stage's median, p99 and max from summary.json's timing_ms: the fallback for results
    folders written before timing.csv."""
    timing = summary.get("timing_ms", {})
    stages = [s for s in timing if timing[s].get("count", 0) > 0]
    fig, ax = plt.subplots(figsize=(10, 0.45 * len(stages) + 1.5))
    y = np.arange(len(stages))
    for key, color, label in [("max", "#f4c7a1", "max"), ("p99", "#e8833a", "p99"), ("median", "#1f5f99", "median")]:
        ax.barh(y, [timing[s][key] for s in stages], color=color, label=label)
    ax.set_yticks(y, [f"{s} (n={timing[s]['count']})" for s in stages])
    ax.invert_yaxis()
    ax.set_xscale("log")
    ax.set_xlabel("wall-clock time per call [ms]")
    ax.set_title("Latency per stage (median, p99, max over the run)")
    ax.grid(axis="x", alpha=0.3)
    ax.legend(fontsize=8, loc="lower right")
    return save(fig, out, "latency.png")


def plot_window_strip(results, windows, out, n=6):
    """Window images (`fdv run --visualize`) spread over the windows with a detection."""
    folder = results / "windows"
    if not folder.is_dir():
        return None
    files = sorted(folder.glob("window_*.png"))
    index = {int(f.stem.split("_")[1]): f for f in files}
    with_detection = [i for i, w in enumerate(windows) if w["detections"] and i in index] or sorted(index)
    if not with_detection:
        return None
    picks = [with_detection[i] for i in np.unique(np.linspace(0, len(with_detection) - 1, n).round().astype(int))]
    images = [plt.imread(index[i]) for i in picks]
    fig, axes = plt.subplots(len(images), 1, figsize=(10, 10 * images[0].shape[0] / images[0].shape[1] * len(images) + 0.5))
    for ax, img, i in zip(np.atleast_1d(axes), images, picks):
        ax.imshow(img)
        ax.set_axis_off()
    fig.suptitle("Window images: mean-time image N, segmentation, event count with the detection box")
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    fig.savefig(out / "windows.png", dpi=90)
    plt.close(fig)
    return "windows.png"


def write_report(results_dir, truth_dir=None, out_dir=None):
    results = Path(results_dir)
    out = Path(out_dir) if out_dir else results / "report"
    if out.exists() and not out.is_dir():
        raise ReportError(f"{out}: exists and is not a folder: name a folder for the report")
    if not (results / "detections.jsonl").exists():
        raise ReportError(f"{results}: not a `fdv run` results folder (no detections.jsonl)")
    summary = read_summary(results)
    windows = read_jsonl(results / "detections.jsonl")
    trajectories = read_jsonl(results / "trajectories.jsonl")
    predictions = read_jsonl(results / "predictions.jsonl")
    dodge = read_jsonl(results / "dodge.jsonl")
    truth = Truth(truth_dir) if truth_dir else None
    if truth:
        check_truth_matches(summary, truth, truth_dir)
    out.mkdir(parents=True, exist_ok=True)

    sections = [("Detection timeline", [plot_timeline(windows, truth, out)])]
    sections.append(("3D trajectories (final usable fusion estimate per track)",
                     plot_trajectories(results, trajectories, truth, out)))
    sections.append(("Prediction error", [plot_prediction_error(windows, trajectories, predictions, truth, out)]))
    radius = summary.get("options", {}).get("prediction", {}).get("safety_radius_m", 0.5)
    dodge_plot = plot_dodge(results, dodge, predictions, truth, radius, out)
    if dodge_plot:
        sections.append(("Dodge", [dodge_plot]))
    timing = read_timing(results)
    if timing is not None and timing.size:
        sections.append(("Latency per stage", [plot_latency_histograms(timing, out)]))
    elif summary.get("timing_ms"):
        sections.append(("Latency per stage", [plot_latency(summary, out)]))
    strip = plot_window_strip(results, windows, out)
    sections.append(("Window images", [strip] if strip else []))

    counts = summary.get("counts", {})
    rows = "".join(f"<tr><td>{html.escape(k)}</td><td>{html.escape(str(counts[k]))}</td></tr>"
                   for k in ["events_read", "windows", "detections", "depth_observations", "estimates"] if k in counts)
    warnings = "".join(f"<li>{html.escape(w)}</li>" for w in summary.get("warnings", []))
    body = []
    for title, images in sections:
        body.append(f"<h2>{html.escape(title)}</h2>")
        if not images:
            body.append("<p class=note>Nothing to show" + (" (run `fdv run --visualize` for window images)"
                                                            if title == "Window images" else "") + ".</p>")
        body.extend(f'<img src="{html.escape(name)}" alt="{html.escape(name)}">' for name in images)
    page = f"""<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>fdv report: {html.escape(str(results))}</title>
<style>body {{ font-family: sans-serif; max-width: 1000px; margin: 1em auto; }}
img {{ max-width: 100%; display: block; margin: 0.5em 0; }} td {{ padding: 0 1em 0 0; }}
.note {{ color: #666; }}</style></head><body>
<h1>fdv report</h1>
<p>Results <code>{html.escape(str(results.resolve()))}</code>
{f"(input <code>{html.escape(summary.get('input', ''))}</code>, {html.escape(summary.get('format', ''))}, compensation {html.escape(summary.get('method', ''))})" if summary else ""}
{f"<br>Truth <code>{html.escape(str(Path(truth_dir).resolve()))}</code>" if truth_dir else ""}</p>
<table>{rows}</table>
{f"<h3>Warnings</h3><ul>{warnings}</ul>" if warnings else ""}
{"".join(body)}
</body></html>
"""
    (out / "report.html").write_text(page)
    return out / "report.html"


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python3 -m fdv.report", description=__doc__.split("\n\n")[0])
    parser.add_argument("results", help="a `fdv run` results folder")
    parser.add_argument("--truth", help="the simulated dataset folder it ran on (fdv simulate)")
    parser.add_argument("--out", help="output folder (default RESULTS/report)")
    args = parser.parse_args(argv)
    try:
        print(write_report(args.results, args.truth, args.out))
    except (ReportError, OSError) as e:  # the file and the reason, not a traceback
        sys.exit(f"fdv.report: {e}")


if __name__ == "__main__":
    main()
