"""``flowvo report``: one self-contained HTML page (plus PNGs) comparing runs of ``flowvo run``.

Every number is recomputed from the pose files with :func:`flowvo.report.evaluation.evaluate`, the same code as
``flowvo eval``. Published figures of the reference system are shown beside ours and labelled so.
"""

from __future__ import annotations

import html
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from flowvo.errors import FlowvoError
from flowvo.io.atomic import strict_json_dumps, write_text_atomic
from flowvo.io.outputs import prepare_output_dir, validate_name
from flowvo.kitti.poses import read_kitti_poses
from flowvo.kitti.sequence import KittiSequence
from flowvo.methods.stages import STAGES, stage_seconds_text
from flowvo.metrics.kitti_odometry import SEGMENT_LENGTHS_M
from flowvo.report import plots
from flowvo.report.evaluation import Evaluation, evaluate, format_lengths, pooled_summary
from flowvo.report.reference_system import REFERENCE_FIGURES, REFERENCE_LABEL, REFERENCE_SECONDS_PER_FRAME

RUN_KEYS = ("label", "sequence", "data", "synthetic", "frames", "poses")
MIN_FRAMES = 2  # what flowvo run needs and writes
TIMING_STAGES = ("image_read", "flow", "network", "total")


@dataclass
class RunRecord:
    """One run folder: its summary, timing, its poses and the evaluation recomputed from them."""

    folder: Path
    summary: dict
    timing: dict
    evaluation: Evaluation | None
    positions: np.ndarray  # (N, 3) camera centres of its pose file, metres

    @property
    def kind(self) -> str:
        """What the drive was: synthetic, KITTI (a dataset folder), video or bag."""
        if self.summary["synthetic"]:
            return "synthetic"
        source = self.summary.get("source") if isinstance(self.summary.get("source"), dict) else {}
        return "video" if source.get("video") else "bag" if source.get("bag") else "KITTI"


def load_run(folder: str | Path, lengths_m: tuple[float, ...] | None = None) -> RunRecord:
    """Read run.json, timing.json and the poses of a ``flowvo run`` output folder; evaluate on
    ``lengths_m`` (default: the run's own, recorded in run.json, else the devkit's)."""
    folder = Path(folder)
    summary = _read_record(folder / "run.json", RUN_KEYS)
    if not all(isinstance(summary[key], str) for key in ("label", "sequence", "poses")) \
            or not isinstance(summary["data"], str | None) or not isinstance(summary["synthetic"], bool):
        raise FlowvoError("label, sequence and poses must be text, data text or null, synthetic true or false",
                          folder / "run.json")
    try:
        validate_name(summary["sequence"], "run.json 'sequence'")
    except FlowvoError as error:
        raise FlowvoError(error.message, folder / "run.json") from None
    frames = summary["frames"]
    if isinstance(frames, bool) or not isinstance(frames, int) or frames < MIN_FRAMES:
        raise FlowvoError(f"'frames' must be a whole number of at least {MIN_FRAMES}, got {frames!r}",
                          folder / "run.json")
    lengths_m = lengths_m or _run_lengths(summary, folder / "run.json")
    timing = _read_record(folder / "timing.json", ("seconds_per_frame",))
    seconds = timing["seconds_per_frame"]
    if not isinstance(seconds, dict) or not all(_is_seconds(seconds.get(k)) for k in TIMING_STAGES) \
            or seconds["total"] <= 0:
        raise FlowvoError(f"seconds_per_frame must give {', '.join(TIMING_STAGES)} as seconds (total > 0)",
                          folder / "timing.json")
    evaluation = None
    poses = read_kitti_poses(folder / validate_name(summary["poses"], "run.json 'poses' file"))
    sequence = KittiSequence(summary["data"], summary["sequence"]) if summary["data"] else None
    if sequence is not None and sequence.has_poses:
        evaluation = evaluate(sequence.poses, poses, lengths_m=lengths_m)
    return RunRecord(folder, summary, timing, evaluation, poses.positions)


def _run_lengths(summary: dict, path: Path) -> tuple[float, ...]:
    """The sub-path lengths the run was evaluated on (run.json ``lengths_m``), else the devkit's."""
    lengths = summary.get("lengths_m", list(SEGMENT_LENGTHS_M))
    if not isinstance(lengths, list) or not lengths or not all(
            isinstance(v, int | float) and not isinstance(v, bool) and 1.0 <= v <= 1e5 for v in lengths):
        raise FlowvoError("'lengths_m' must be a list of sub-path lengths in [1, 1e5] m", path)
    return tuple(sorted({float(v) for v in lengths}))


def _is_seconds(value: object) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and 0 <= value < float("inf")


def _read_record(path: Path, keys: tuple[str, ...]) -> dict:
    """A JSON object written by ``flowvo run``, checked to hold ``keys``; errors name the file."""
    if not path.is_file():
        raise FlowvoError(f"not a flowvo run folder (no {path.name})", path.parent)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as error:
        raise FlowvoError(f"not valid JSON ({getattr(error, 'msg', 'not UTF-8 text')})", path,
                          getattr(error, "lineno", None)) from None
    missing = [key for key in keys if not isinstance(data, dict) or key not in data]
    if missing:
        raise FlowvoError(f"lacks {', '.join(missing)}: not written by flowvo run, or damaged", path)
    return data


def _fmt(value: float | None, digits: int) -> str:
    return "n/a" if value is None else f"{value:.{digits}f}"


def _results_table(runs: list[RunRecord]) -> tuple[str, list[dict]]:
    rows, records = [], []
    for run in runs:
        m = run.evaluation.metrics if run.evaluation else {}
        record = {"method": run.summary["label"], "sequence": run.summary["sequence"],
                  "synthetic": run.summary["synthetic"], "frames": run.summary["frames"],
                  "t_err_percent": m.get("t_err_percent"), "r_err_deg_per_m": m.get("r_err_deg_per_m"),
                  "ate_rmse_m": m.get("ate_rmse_m")}
        records.append(record)
        rows.append(f"<tr><td>{html.escape(record['method'])}</td><td>{html.escape(record['sequence'])} "
                    f"({run.kind})</td>"
                    f"<td>{record['frames']}</td><td>{_fmt(record['t_err_percent'], 2)}</td>"
                    f"<td>{_fmt(record['r_err_deg_per_m'], 4)}</td><td>{_fmt(record['ate_rmse_m'], 2)}</td></tr>")
    methods = sorted({r["method"] for r in records})
    for method in methods:
        mine = [r for r in records if r["method"] == method and r["t_err_percent"] is not None]
        if len(mine) < 1:
            continue
        frames = sum(r["frames"] for r in mine)
        t = sum(r["t_err_percent"] * r["frames"] for r in mine) / frames
        r_ = sum(r["r_err_deg_per_m"] * r["frames"] for r in mine) / frames
        rows.append(f"<tr class='avg'><td>{html.escape(method)}</td><td>frame-weighted average</td>"
                    f"<td>{frames}</td><td>{t:.2f}</td><td>{r_:.4f}</td><td></td></tr>")
    for sequence, (t, r) in REFERENCE_FIGURES.items():
        rows.append(f"<tr class='ref'><td>{REFERENCE_LABEL}</td><td>{sequence} (real KITTI)</td><td></td>"
                    f"<td>{t:.2f}</td><td>{r:.4f}</td><td></td></tr>")
    header = ("<tr><th>method</th><th>sequence</th><th>frames</th><th>t_err [%]</th><th>r_err [deg/m]</th>"
              "<th>ATE [m]</th></tr>")
    return f"<table>{header}{''.join(rows)}</table>", records


def _timing_table(runs: list[RunRecord]) -> str:
    baseline_totals: dict[str, float] = {}  # per sequence: the first classical run given
    for run in runs:
        if run.summary.get("method") == "classical":
            baseline_totals.setdefault(run.summary["sequence"], run.timing["seconds_per_frame"]["total"])
    rows = []
    for run in runs:
        spf = run.timing["seconds_per_frame"]
        baseline_total = baseline_totals.get(run.summary["sequence"])
        versus_base = f"{baseline_total / spf['total']:.1f}x" if baseline_total and spf["total"] else "n/a"
        method = run.summary.get("method", "")
        stages = "".join(f"<td>{stage_seconds_text(method, stage, spf.get(stage))}</td>" for stage in STAGES)
        rows.append(f"<tr><td>{html.escape(run.summary['label'])}</td><td>{html.escape(run.summary['sequence'])}"
                    f"</td>{stages}"
                    f"<td>{spf['total']:.4f}</td><td>{REFERENCE_SECONDS_PER_FRAME / spf['total']:.1f}x</td>"
                    f"<td>{versus_base}</td></tr>")
    blanks = "<td></td>" * len(STAGES)
    rows.append(f"<tr class='ref'><td>{REFERENCE_LABEL} (GPU)</td><td>08-10</td>{blanks}"
                f"<td>{REFERENCE_SECONDS_PER_FRAME:.3f}</td><td>1.0x</td><td></td></tr>")
    header = ("<tr><th>method</th><th>sequence</th>" + "".join(f"<th>{stage} [s/frame]</th>" for stage in STAGES)
              + "<th>total [s/frame]</th><th>speed-up vs reference</th><th>speed-up vs baseline</th></tr>")
    return f"<table>{header}{''.join(rows)}</table>"


def _figures(runs: list[RunRecord], out: Path) -> list[tuple[str, str]]:
    """Per drive: the bird's-eye paths of every run (with ground truth when there is one), and with ground
    truth the error curves and histograms; files named after the sequence (and its kind when two drives
    share a name)."""
    figures = []
    drives = sorted({(r.summary["sequence"], r.kind) for r in runs})
    for sequence, kind in drives:
        number = sequence if [s for s, _ in drives].count(sequence) == 1 else f"{sequence}_{kind}"
        mine = [r for r in runs if (r.summary["sequence"], r.kind) == (sequence, kind)]
        scored = [r for r in mine if r.evaluation]
        gt = scored[0].evaluation.gt.positions if scored else None
        paths = {r.summary["label"]: r.positions for r in mine}
        name = f"path_{number}.png"
        plots.plot_paths(paths, gt, f"{sequence} ({kind}): x-z path", out / name)
        figures.append((name, f"{sequence} ({kind}): bird's-eye path" + (", ground truth vs each method" if gt
                                                                        is not None else " (no ground truth)")))
        if not scored:
            continue
        axes = (("per_length", "length_m", "path length [m]", "length"),
                ("per_speed", "speed_mps", "speed [m/s]", "speed"))
        for key, x_key, label, stem in axes:
            curves = {r.summary["label"]: r.evaluation.metrics[key] for r in scored}
            for written in plots.plot_error_curves(curves, x_key, label, f"{stem}_{number}", out):
                figures.append((written.name, f"{sequence}: {written.stem.rsplit('_', 1)[0].replace('_', ' ')}"))
        histogram = plots.plot_frame_error_histograms({r.summary["label"]: r.evaluation.frame_errors for r in scored},
                                                       out / f"frame_errors_{number}.png")
        figures.append((histogram.name, f"{sequence}: per-frame translation (m) and rotation (deg) errors"))
    return figures


def _script_safe(text: str) -> str:
    """JSON that cannot end its ``<script>`` element early (``</script>`` in a label) or open a comment:
    ``<``, ``>`` and ``&`` as JSON unicode escapes, which parse back to the same text."""
    return text.replace("<", "\\u003c").replace(">", "\\u003e").replace("&", "\\u0026")


STYLE = """body{font-family:sans-serif;max-width:1100px;margin:2em auto;color:#222}
table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #bbb;padding:4px 8px;text-align:right}
td:first-child,th:first-child{text-align:left}tr.avg{font-weight:bold;background:#eef}
tr.ref{font-style:italic;background:#f6f6f6}img{max-width:100%;border:1px solid #ddd}
.note{background:#fff6d5;padding:8px;border-left:4px solid #e0b000}
figure{display:inline-block;vertical-align:top;width:48%;margin:0.5em 1%}figure.wide{width:70%}"""


def write_report(run_folders: list[str | Path], out_dir: str | Path, force: bool = False,
                 lengths_m: tuple[float, ...] | None = None) -> Path:
    """Write ``out_dir/index.html`` and its PNGs; returns the HTML path. An earlier report there is
    refused unless ``force``. ``lengths_m``: the sub-paths to score (default each run's own)."""
    if not run_folders:
        raise FlowvoError("no run folders given")
    runs = [load_run(folder, lengths_m) for folder in run_folders]
    lengths = sorted({tuple(r.evaluation.metrics["segment_lengths_m"]) for r in runs if r.evaluation})
    out = prepare_output_dir(out_dir, ["index.html"], force)
    results_html, records = _results_table(runs)
    figures = _figures(runs, out)
    synthetic = any(r.summary["synthetic"] for r in runs)
    pooled = {}
    for method in sorted({r.summary["label"] for r in runs}):
        evaluations = [r.evaluation for r in runs if r.summary["label"] == method and r.evaluation
                       and r.evaluation.metrics["segments"]]
        if evaluations:
            pooled[method] = pooled_summary(evaluations)
    pooled_rows = "".join(
        f"<tr><td>{html.escape(m)}</td><td>{p['t_err_percent']:.2f}</td><td>{p['r_err_deg_per_m']:.4f}</td>"
        f"<td>{p['segments']}</td></tr>" for m, p in pooled.items())
    note = ("<p class='note'><b>Synthetic data.</b> Sequences marked synthetic were rendered by flowvo synth; "
            "their numbers are not comparable with results on real KITTI frames. The reference system's "
            "figures are published results on real KITTI.</p>") if synthetic else ""
    body = [
        "<h1>flowvo odometry report</h1>", note,
        "<h2>Average errors per sequence (KITTI odometry metric, "
        f"{' / '.join(format_lengths(L) for L in lengths) or 'no ground truth'} sub-paths)</h2>", results_html,
        "<h3>All segments pooled (the KITTI multi-sequence average)</h3>",
        "<table><tr><th>method</th><th>t_err [%]</th><th>r_err [deg/m]</th><th>segments</th></tr>"
        f"{pooled_rows}</table>",
        "<h2>Timing on this machine</h2>", _timing_table(runs),
        "<p>Seconds per frame by stage, streaming one frame at a time; image reading runs in its own thread, "
        "overlapped with the others, and the total is wall-clock. Speed-ups divide the reference system's "
        f"{REFERENCE_SECONDS_PER_FRAME} s/frame (GPU) and the same sequence's first classical run by each "
        "method's total.</p>",
        "<h2>Figures</h2>",
        *(f"<figure{' class=wide' if name.startswith(('path_', 'frame_errors_')) else ''}><img src='{name}' "
          f"alt='{html.escape(caption)}'><figcaption>{html.escape(caption)}</figcaption></figure>"
          for name, caption in figures),
        f"<script type='application/json' id='results'>{_script_safe(strict_json_dumps(records))}</script>",
    ]
    page = (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>flowvo report</title>"
            f"<style>{STYLE}</style></head><body>{''.join(body)}</body></html>\n")
    write_text_atomic(out / "index.html", page)
    return out / "index.html"
