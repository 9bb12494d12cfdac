"""Evaluation figures as PNG: x-z paths, errors vs path length and speed, per-frame error histograms."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from flowvo.io.atomic import atomic_path  # noqa: E402


def _save(figure: plt.Figure, path: Path) -> Path:
    with atomic_path(path) as tmp:
        figure.savefig(tmp, dpi=110, bbox_inches="tight", format="png")
    plt.close(figure)
    return path


def plot_paths(paths: dict[str, np.ndarray], gt_positions: np.ndarray | None, title: str, path: Path) -> Path:
    """Bird's-eye x-z plot (metres) of ground truth (when there is one) and predicted camera centres,
    start marked."""
    figure, axis = plt.subplots(figsize=(6.5, 6.5))
    if gt_positions is not None:
        axis.plot(gt_positions[:, 0], gt_positions[:, 2], "k-", lw=2, label="ground truth")
    for name, positions in paths.items():
        axis.plot(positions[:, 0], positions[:, 2], lw=1.5, label=name)
    start = gt_positions if gt_positions is not None else next(iter(paths.values()))
    axis.plot(start[0, 0], start[0, 2], "ks", ms=9, label="start")
    axis.set_xlabel("x [m]")
    axis.set_ylabel("z [m]")
    axis.set_aspect("equal", adjustable="datalim")
    axis.grid(alpha=0.3)
    axis.legend(loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=2, fontsize="small")  # off the paths
    axis.set_title(title)
    return _save(figure, path)


CURVE_STYLES = ("o-", "s--", "^:", "D-.")


def plot_error_curves(curves: dict[str, list[dict]], key: str, xlabel: str, stem: str, out: Path) -> list[Path]:
    """t_err (%) and r_err (deg/100m) against ``key`` (length_m or speed_mps), one line per method."""
    written = []
    axes_labels = (("t_err_percent", "translation error [%]"), ("r_err_deg_per_100m", "rotation error [deg/100m]"))
    for metric, ylabel in axes_labels:
        figure, axis = plt.subplots(figsize=(6, 4))
        for index, (name, rows) in enumerate(curves.items()):
            if rows:  # later methods drawn thinner and dashed, so identical curves stay visible
                axis.plot([r[key] for r in rows], [r[metric] for r in rows], CURVE_STYLES[index % len(CURVE_STYLES)],
                          lw=2.2 - 0.5 * min(index, 2), ms=8 - 2 * min(index, 2), label=name)
        axis.set_xlabel(xlabel)
        axis.set_ylabel(ylabel)
        axis.grid(alpha=0.3)
        axis.set_ylim(bottom=0)
        if axis.get_legend_handles_labels()[0]:  # no curve when the path has no 100 m segment
            axis.legend(loc="upper center", bbox_to_anchor=(0.5, -0.16), fontsize="small")
        short = "t_err" if metric.startswith("t") else "r_err"
        written.append(_save(figure, out / f"{short}_vs_{stem}.png"))
    return written


def plot_frame_error_histograms(frame_errors: dict[str, dict[str, np.ndarray]], path: Path) -> Path:
    """Histograms of per-frame translation error (m) and rotation error (deg), one outline per method.

    All methods share bins from 0 to the 99th percentile of their pooled errors; larger errors are counted
    in the last bin, so long tails neither vanish nor squash the bulk.
    """
    figure, axes = plt.subplots(1, 2, figsize=(10, 3.8))
    panels = (("translation_error_m", "per-frame translation error [m]"),
              ("rotation_error_deg", "per-frame rotation error [deg]"))
    for axis, (key, label) in zip(axes, panels, strict=True):
        pooled = np.concatenate([errors[key] for errors in frame_errors.values()])
        top = float(np.percentile(pooled, 99)) if len(pooled) else 1.0
        bins = np.linspace(0.0, top if top > 0 else 1.0, 41)
        for name, errors in frame_errors.items():
            axis.hist(np.minimum(errors[key], bins[-1]), bins=bins, histtype="step", lw=1.8, label=name)
        axis.set_xlabel(label)
        axis.set_ylabel("frames")
        axis.grid(alpha=0.3)
    handles, names = axes[0].get_legend_handles_labels()
    figure.legend(handles, names, loc="upper center", bbox_to_anchor=(0.5, 0.0), ncol=2, fontsize="small",
                  title="last bin: errors at or above the 99th percentile", title_fontsize="small")
    return _save(figure, path)


def save_evaluation_plots(evaluation, out: Path, name: str = "prediction") -> list[Path]:
    """All figures of one evaluation into ``out``."""
    written = [
        plot_paths(
            {name: evaluation.pred.positions},
            evaluation.gt.positions,
            "x-z path (bird's-eye view)",
            out / "path_xz.png",
        )
    ]
    written += plot_error_curves({name: evaluation.metrics["per_length"]}, "length_m", "path length [m]", "length", out)
    written += plot_error_curves({name: evaluation.metrics["per_speed"]}, "speed_mps", "speed [m/s]", "speed", out)
    written.append(plot_frame_error_histograms({name: evaluation.frame_errors}, out / "frame_error_histograms.png"))
    return written


def plot_path_thumbnail(positions_m: np.ndarray, gt_positions_m: np.ndarray | None, title: str, path: Path) -> Path:
    """A small bird's-eye x-z plot (metres) of one drive's camera centres (N, 3), ground truth in black when
    given; the start is marked."""
    figure, axis = plt.subplots(figsize=(2.2, 2.2))
    if gt_positions_m is not None:
        axis.plot(gt_positions_m[:, 0], gt_positions_m[:, 2], "k-", lw=1.2)
    axis.plot(positions_m[:, 0], positions_m[:, 2], "-", color="tab:blue", lw=1.2)
    axis.plot(positions_m[0, 0], positions_m[0, 2], "ks", ms=4)
    axis.set_aspect("equal", adjustable="datalim")
    axis.tick_params(labelsize=6)
    axis.grid(alpha=0.3)
    axis.set_title(title, fontsize=7)
    return _save(figure, path)
