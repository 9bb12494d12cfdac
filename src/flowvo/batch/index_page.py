"""The fleet page: ``OUT/index.html``, one row per drive with a small path plot (``OUT/plots/NAME.png``),
failed drives first, then those not run, then the completed ones."""

from __future__ import annotations

import html
from pathlib import Path
from typing import Any

from flowvo.batch.done import DriveOutputs
from flowvo.batch.record import DriveSummary
from flowvo.batch.spec import Drive
from flowvo.errors import FlowvoError
from flowvo.io.atomic import write_text_atomic
from flowvo.kitti.poses import read_kitti_poses

_ORDER = {"failed": 0, "pending": 1, "ok": 2}
_COLUMNS = (("frames", "frames", "{:d}"), ("duration_s", "seconds", "{:.1f}"), ("path_length_m", "path [m]", "{:.1f}"),
            ("t_err_percent", "t_err [%]", "{:.2f}"), ("r_err_deg_per_m", "r_err [deg/m]", "{:.4f}"),
            ("frames_per_second", "frames/s", "{:.0f}"), ("unscaled_steps", "unscaled steps", "{:d}"),
            ("wall_s", "wall [s]", "{:.1f}"),
            ("peak_memory_mib", "peak [MiB]", "{:.0f}"))
_STYLE = ("body{font-family:sans-serif;margin:1.5em}table{border-collapse:collapse}"
          "td,th{border:1px solid #ccc;padding:3px 6px;font-size:13px;vertical-align:middle}"
          "tr.failed td{background:#fde8e8}tr.pending td{background:#f3f3f3}td.num{text-align:right}"
          "td.error{max-width:40em;font-family:monospace;font-size:12px}")


def thumbnail_path(out: str | Path, name: str) -> Path:
    """Where the path plot of drive ``name`` goes."""
    return Path(out) / "plots" / f"{name}.png"


def write_thumbnail(drive: Drive, outputs: DriveOutputs, out: str | Path) -> Path:
    """Draw the drive's x-z path (and its ground truth, for a KITTI sequence that has one)."""
    from flowvo.report.plots import plot_path_thumbnail

    gt_positions_m = None
    if drive.kind == "kitti":
        gt_file = Path(drive.path) / "poses" / f"{drive.sequence}.txt"
        if gt_file.is_file():
            try:
                gt_positions_m = read_kitti_poses(gt_file).T_world_cam[: outputs.frames, :3, 3]
            except FlowvoError:
                gt_positions_m = None  # the run itself reports a damaged ground truth
    return plot_path_thumbnail(outputs.positions_m, gt_positions_m, drive.name, thumbnail_path(out, drive.name))


def write_index(out: str | Path, rows: list[DriveSummary], totals: dict[str, Any]) -> Path:
    """Write ``OUT/index.html`` for ``rows`` (plots linked where they exist) and the batch ``totals``."""
    out = Path(out)
    ordered = sorted(rows, key=lambda row: (_ORDER.get(row.status, 0), row.drive))
    head = "".join(f"<th>{title}</th>" for _, title, _ in _COLUMNS)
    lines = [f"<tr><th>status</th><th>drive</th><th>path plot</th><th>kind</th>{head}<th>error</th></tr>"]
    for row in ordered:
        plot = thumbnail_path(out, row.drive)
        picture = (f"<img src='plots/{html.escape(plot.name)}' loading='lazy' alt='path of {html.escape(row.drive)}'>"
                   if row.status == "ok" and plot.is_file() else "")
        cells = "".join(f"<td class='num'>{_format(getattr(row, key), spec)}</td>" for key, _, spec in _COLUMNS)
        status = row.status + (" (earlier run)" if row.reused else "")
        lines.append(f"<tr class='{row.status}'><td>{status}</td>"
                     f"<td><a href='{html.escape(row.output)}/'>{html.escape(row.drive)}</a><br>"
                     f"<small>{html.escape(row.source)}</small></td><td>{picture}</td><td>{row.kind}</td>{cells}"
                     f"<td class='error'>{html.escape(row.error or '')}</td></tr>")
    counts = ", ".join(f"{totals.get(status, 0)} {status}" for status in ("ok", "failed", "pending"))
    throughput = totals.get("frames_per_second")
    speed = f"; this run: {totals.get('frames_run', 0)} frames, {throughput:.1f} frames/s over the batch" \
        if throughput else ""
    page = (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>flowvo batch</title><style>{_STYLE}</style>"
            f"</head><body><h1>flowvo batch: {len(rows)} drives</h1><p>{counts}{speed}. Summary: "
            "<a href='summary.csv'>summary.csv</a>, <a href='summary.json'>summary.json</a>. Paths: x-z in metres, "
            "ground truth in black where it exists.</p>"
            f"<table>{''.join(lines)}</table></body></html>\n")
    write_text_atomic(out / "index.html", page)
    return out / "index.html"


def _format(value: Any, spec: str) -> str:
    return "" if value is None else spec.format(value)
