"""``flowvo report``: one self-contained HTML page (plus PNGs) comparing runs of ``flowvo run``.

Every number is recomputed from the run folders' files: what each drive did (distance, speeds, heading) from
its poses and timestamps (:mod:`flowvo.report.drive_summary`), for runs with ground truth the errors with
:func:`flowvo.report.evaluation.evaluate`, the same code as ``flowvo eval``. Published figures of the reference
system (on real KITTI) are shown beside ours, labelled so, only when some run has ground truth.
"""

from __future__ import annotations

import html
from pathlib import Path

import numpy as np

from flowvo.errors import FlowvoError
from flowvo.io.atomic import strict_json_dumps, write_text_atomic
from flowvo.io.outputs import prepare_output_dir
from flowvo.methods.stages import STAGES, stage_seconds_text
from flowvo.report import plots
from flowvo.report.evaluation import format_lengths, pooled_summary
from flowvo.report.reference_system import REFERENCE_FIGURES, REFERENCE_LABEL, REFERENCE_SECONDS_PER_FRAME
from flowvo.report.run_record import RunRecord, load_run

__all__ = ["RunRecord", "load_run", "write_report"]


def _fmt(value: float | None, digits: int) -> str:
    return "n/a" if value is None else f"{value:.{digits}f}"


def _record(run: RunRecord) -> dict:
    """The run's numbers as the page's JSON holds them: what ran, what the drive did and, with ground truth,
    the KITTI metric and ATE (null without)."""
    m = run.evaluation.metrics if run.evaluation else {}
    return {"run_folder": str(run.folder), "method": run.summary["label"], "sequence": run.summary["sequence"],
            "kind": run.kind, "synthetic": run.summary["synthetic"], "frames": run.summary["frames"],
            "camera_height_m": run.camera.get("camera_height_m"), "drive": run.drive,
            "ground_truth": run.evaluation is not None, "t_err_percent": m.get("t_err_percent"),
            "r_err_deg_per_m": m.get("r_err_deg_per_m"), "ate_rmse_m": m.get("ate_rmse_m")}


def _camera_cells(camera: dict) -> str:
    """The camera (where its intrinsics came from, fx) and its height above the road, as two cells."""
    if not camera:
        return "<td></td><td></td>"
    fx = camera.get("fx")
    intrinsics = html.escape(str(camera.get("source", "")))
    if isinstance(fx, int | float) and not isinstance(fx, bool):
        intrinsics += f", fx {fx:.1f} px"
    height = camera.get("camera_height_m")
    height_text = f"{height:g}" if isinstance(height, int | float) else ""
    if height_text and camera.get("camera_height_given") is False and camera.get("source") != "kitti":
        height_text += " (assumed)"
    return f"<td>{intrinsics}</td><td>{height_text}</td>"


def _drive_table(runs: list[RunRecord]) -> str:
    """Per run: what ran on which drive, and what the drive did by its own poses (no ground truth needed)."""
    rows = []
    for run in runs:
        d = run.drive
        numbers = "<td colspan='5'>no timestamps in this run folder</td>" if d is None else (
            f"<td>{d['distance_m']:.1f}</td><td>{d['duration_s']:.1f}</td><td>{d['mean_speed_mps']:.1f}</td>"
            f"<td>{d['top_speed_mps']:.1f}</td><td>{d['heading_change_deg']:+.1f}</td>")
        rows.append(f"<tr><td>{html.escape(str(run.folder))}</td><td>{html.escape(run.summary['label'])}</td>"
                    f"<td>{html.escape(run.summary['sequence'])} ({run.kind})</td>{_camera_cells(run.camera)}"
                    f"<td>{run.summary['frames']}</td>{numbers}</tr>")
    header = ("<tr><th>run folder</th><th>method</th><th>drive</th><th>camera</th><th>height [m]</th>"
              "<th>frames</th><th>distance [m]</th><th>duration [s]</th><th>mean speed [m/s]</th>"
              "<th>top speed, 1 s [m/s]</th><th>heading change [deg, left +]</th></tr>")
    return f"<table>{header}{''.join(rows)}</table>"


def _results_table(runs: list[RunRecord]) -> str:
    """The errors of the runs with ground truth: the KITTI metric (its columns, each method's frame-weighted
    average and the reference system's published figures only when some path is long enough for a sub-path)
    and ATE."""
    scored = [run for run in runs if run.evaluation is not None]
    kitti = any(run.evaluation.metrics["t_err_percent"] is not None for run in scored)
    rows = []
    for run in scored:
        m = run.evaluation.metrics
        metric = f"<td>{_fmt(m['t_err_percent'], 2)}</td><td>{_fmt(m['r_err_deg_per_m'], 4)}</td>" if kitti else ""
        rows.append(f"<tr><td>{html.escape(run.summary['label'])}</td><td>{html.escape(run.summary['sequence'])} "
                    f"({run.kind})</td><td>{run.summary['frames']}</td>{metric}<td>{m['ate_rmse_m']:.2f}</td></tr>")
    for method in sorted({run.summary["label"] for run in scored}) if kitti else ():
        mine = [(run.summary["frames"], run.evaluation.metrics) for run in scored
                if run.summary["label"] == method and run.evaluation.metrics["t_err_percent"] is not None]
        if not mine:
            continue
        frames = sum(f for f, _ in mine)
        t = sum(m["t_err_percent"] * f for f, m in mine) / frames
        r_ = sum(m["r_err_deg_per_m"] * f for f, m in mine) / frames
        rows.append(f"<tr class='avg'><td>{html.escape(method)}</td><td>frame-weighted average</td>"
                    f"<td>{frames}</td><td>{t:.2f}</td><td>{r_:.4f}</td><td></td></tr>")
    for sequence, (t, r) in REFERENCE_FIGURES.items() if kitti else ():
        rows.append(f"<tr class='ref'><td>{REFERENCE_LABEL}</td><td>{sequence} (real KITTI)</td><td></td>"
                    f"<td>{t:.2f}</td><td>{r:.4f}</td><td></td></tr>")
    header = ("<tr><th>method</th><th>sequence</th><th>frames</th>"
              + ("<th>t_err [%]</th><th>r_err [deg/m]</th>" if kitti else "") + "<th>ATE [m]</th></tr>")
    return f"<table>{header}{''.join(rows)}</table>"


def _timing_table(runs: list[RunRecord], reference: bool) -> str:
    """Seconds per frame by stage; with ``reference``, the reference system's published rate beside them."""
    baseline_totals: dict[str, float] = {}  # per sequence: the first classical run given
    for run in runs:
        if run.summary.get("method") == "classical":
            baseline_totals.setdefault(run.summary["sequence"], run.timing["seconds_per_frame"]["total"])
    rows, baseline = [], bool(baseline_totals)  # the column only when some run has a classical baseline
    for run in runs:
        spf = run.timing["seconds_per_frame"]
        baseline_total = baseline_totals.get(run.summary["sequence"])
        versus_base = "" if not baseline else \
            f"<td>{baseline_total / spf['total']:.1f}x</td>" if baseline_total else "<td>n/a</td>"
        method = run.summary.get("method", "")
        stages = "".join(f"<td>{stage_seconds_text(method, stage, spf.get(stage))}</td>" for stage in STAGES)
        versus_reference = f"<td>{REFERENCE_SECONDS_PER_FRAME / spf['total']:.1f}x</td>" if reference else ""
        rows.append(f"<tr><td>{html.escape(run.summary['label'])}</td><td>{html.escape(run.summary['sequence'])}"
                    f"</td>{stages}<td>{spf['total']:.4f}</td>{versus_reference}{versus_base}</tr>")
    if reference:
        blanks = "<td></td>" * len(STAGES)
        rows.append(f"<tr class='ref'><td>{REFERENCE_LABEL} (GPU)</td><td>08-10</td>{blanks}"
                    f"<td>{REFERENCE_SECONDS_PER_FRAME:.3f}</td><td>1.0x</td>{'<td></td>' if baseline else ''}</tr>")
    header = ("<tr><th>method</th><th>sequence</th>" + "".join(f"<th>{stage} [s/frame]</th>" for stage in STAGES)
              + "<th>total [s/frame]</th>" + ("<th>speed-up vs reference</th>" if reference else "")
              + ("<th>speed-up vs baseline</th>" if baseline else "") + "</tr>")
    return f"<table>{header}{''.join(rows)}</table>"


def path_names(runs: list[RunRecord]) -> list[str]:
    """A distinct legend name for each run: its method, then, where several runs share one, the run folder's
    name, then the whole folder as given, then a count."""
    names = [run.summary["label"] for run in runs]
    for detail in (lambda run: run.folder.name, lambda run: str(run.folder)):
        names = [f"{run.summary['label']} ({detail(run)})" if names.count(name) > 1 else name
                 for run, name in zip(runs, names, strict=True)]
    repeated, seen = {name for name in names if names.count(name) > 1}, {}
    for index, name in enumerate(names):
        if name in repeated:
            seen[name] = seen.get(name, 0) + 1
            names[index] = f"{name} #{seen[name]}"
    return names


def _figures(runs: list[RunRecord], out: Path) -> list[tuple[str, str]]:
    """Per drive: the bird's-eye paths of every run (with ground truth when there is one), and with ground
    truth the error curves (when a sub-path is long enough) and histograms; files named after the sequence
    (and its kind when two drives share a name); runs of one method told apart by their folders."""
    figures = []
    drives = sorted({(r.summary["sequence"], r.kind) for r in runs})
    for sequence, kind in drives:
        number = sequence if [s for s, _ in drives].count(sequence) == 1 else f"{sequence}_{kind}"
        mine = [r for r in runs if (r.summary["sequence"], r.kind) == (sequence, kind)]
        names = dict(zip(map(id, mine), path_names(mine), strict=True))  # every run drawn, under its own name
        scored = [r for r in mine if r.evaluation]
        gt = None
        if scored:  # the ground truth of the frames run (a run with --max-frames covers the drive's start)
            truth, predicted = scored[0].evaluation.gt, [r.evaluation.pred.frame_ids for r in scored]
            gt = truth.positions[np.isin(truth.frame_ids, np.concatenate(predicted))]
        name = f"path_{number}.png"
        plots.plot_paths({names[id(r)]: r.positions for r in mine}, gt, f"{sequence} ({kind}): x-z path", out / name)
        figures.append((name, f"{sequence} ({kind}): bird's-eye path of each run" + (
            ", ground truth vs each method" if gt is not None else " (no ground truth)")))
        if any(r.evaluation.metrics["segments"] for r in scored):  # no sub-path long enough: no curves
            for key, x_key, label, stem in (("per_length", "length_m", "path length [m]", "length"),
                                            ("per_speed", "speed_mps", "speed [m/s]", "speed")):
                curves = {names[id(r)]: r.evaluation.metrics[key] for r in scored}
                for written in plots.plot_error_curves(curves, x_key, label, f"{stem}_{number}", out):
                    figures.append((written.name,
                                    f"{sequence}: {written.stem.rsplit('_', 1)[0].replace('_', ' ')}"))
        if scored:
            histogram = plots.plot_frame_error_histograms({names[id(r)]: r.evaluation.frame_errors for r in scored},
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
    refused unless ``force``. ``lengths_m``: the sub-paths to score (default each run's own).

    Every run gets its drive's numbers and its path; the odometry errors, their curves and the reference
    system's published figures appear only when some run has ground truth."""
    if not run_folders:
        raise FlowvoError("no run folders given")
    runs = [load_run(folder, lengths_m) for folder in run_folders]
    lengths = sorted({tuple(r.evaluation.metrics["segment_lengths_m"]) for r in runs if r.evaluation})
    out = prepare_output_dir(out_dir, ["index.html"], force)
    records = [_record(run) for run in runs]
    figures = _figures(runs, out)
    synthetic = any(r.summary["synthetic"] for r in runs)
    scored = any(r.evaluation for r in runs)
    note = ("<p class='note'><b>Synthetic data.</b> Sequences marked synthetic were rendered by flowvo synth; "
            "their numbers are not comparable with results on real KITTI frames."
            + (" The reference system's figures are published results on real KITTI." if scored else "")
            + "</p>") if synthetic else ""
    body = ["<h1>flowvo odometry report</h1>", note,
            "<h2>What each drive did (its own poses: no ground truth needed)</h2>", _drive_table(runs),
            "<p>Distance: the path length of the camera centres; top speed: the largest mean speed over any "
            "1 s stretch; heading change: the net turn about the first camera's vertical axis, left positive, "
            "whole turns counted.</p>"]
    if scored:
        body += _errors_section(runs, lengths)
    else:
        body.append("<p>No run has ground truth: odometry errors are not measured.</p>")
    body += [
        "<h2>Timing on this machine</h2>", _timing_table(runs, reference=scored),
        "<p>Seconds per frame by stage, streaming one frame at a time; image reading runs in its own thread, "
        f"overlapped with the others, and the total is wall-clock.{_speed_up_note(runs, scored)}</p>",
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


def _speed_up_note(runs: list[RunRecord], reference: bool) -> str:
    """What the timing table's speed-ups divide, or nothing when it has none."""
    divided = ([f"the reference system's {REFERENCE_SECONDS_PER_FRAME} s/frame (GPU)"] if reference else []) + (
        ["the same sequence's first classical run"] if any(r.summary.get("method") == "classical" for r in runs)
        else [])
    return f" Speed-ups divide {' and '.join(divided)} by each method's total." if divided else ""


def _errors_section(runs: list[RunRecord], lengths: list[tuple[float, ...]]) -> list[str]:
    """The odometry errors of the runs with ground truth: per run, per method pooled."""
    pooled = {}
    for method in sorted({r.summary["label"] for r in runs}):
        evaluations = [r.evaluation for r in runs if r.summary["label"] == method and r.evaluation
                       and r.evaluation.metrics["segments"]]
        if evaluations:
            pooled[method] = pooled_summary(evaluations)
    kitti = any(r.evaluation.metrics["t_err_percent"] is not None for r in runs if r.evaluation)
    sub_paths = f"{' / '.join(format_lengths(L) for L in lengths)} sub-paths"
    what = f"KITTI odometry metric on {sub_paths}, ATE" if kitti else \
        f"ATE; no path is long enough for the KITTI metric's {sub_paths}"
    section = [f"<h2>Errors against ground truth ({what})</h2>", _results_table(runs)]
    if pooled:
        rows = "".join(f"<tr><td>{html.escape(m)}</td><td>{p['t_err_percent']:.2f}</td>"
                       f"<td>{p['r_err_deg_per_m']:.4f}</td><td>{p['segments']}</td></tr>" for m, p in pooled.items())
        section += ["<h3>All segments pooled (the KITTI multi-sequence average)</h3>",
                    f"<table><tr><th>method</th><th>t_err [%]</th><th>r_err [deg/m]</th><th>segments</th></tr>"
                    f"{rows}</table>"]
    return section
