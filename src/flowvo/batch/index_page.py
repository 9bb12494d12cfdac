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
PAGE_WIDTH_PX = 1200  # the table's width: a laptop screen's, whatever the paths and errors (they wrap)
THUMBNAIL_WIDTH_PX = 160
_STYLE = (f"body{{font-family:sans-serif;margin:1.5em;max-width:{PAGE_WIDTH_PX}px}}"
          "table{border-collapse:collapse;table-layout:fixed;width:100%}"
          "td,th{border:1px solid #ccc;padding:3px 6px;font-size:13px;vertical-align:middle;overflow-wrap:anywhere;"
          "text-align:left}"
          f"img{{width:{THUMBNAIL_WIDTH_PX}px;height:auto}}"
          "tr.failed td{background:#fde8e8}tr.pending td{background:#f3f3f3}"
          "td.error{font-family:monospace;font-size:12px}small{color:#555}")


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
    """Write ``OUT/index.html`` for ``rows`` (plots linked where they exist) and the batch ``totals``: per drive
    its status, name and source, path plot, what it drove (distance, duration, mean and top speed, heading
    change), its KITTI metric (a column only when some drive has ground truth), the run's numbers, and its
    error or warnings; :data:`PAGE_WIDTH_PX` wide, long text wrapping in its cell."""
    out = Path(out)
    ordered = sorted(rows, key=lambda row: (_ORDER.get(row.status, 0), row.drive))
    scored = any(row.t_err_percent is not None or row.r_err_deg_per_m is not None for row in rows)
    widths = ["9%", "17%", f"{THUMBNAIL_WIDTH_PX + 14}px", "16%"] + (["12%"] if scored else []) + ["15%", "auto"]
    titles = ["status", "drive", "path plot", "drove"] + (["KITTI metric"] if scored else []) + ["run",
                                                                                                "error, warnings"]
    lines = ["<colgroup>" + "".join(f"<col style='width:{w}'>" for w in widths) + "</colgroup>",
             "<tr>" + "".join(f"<th>{title}</th>" for title in titles) + "</tr>"]
    for row in ordered:
        plot = thumbnail_path(out, row.drive)
        picture = (f"<img src='plots/{html.escape(plot.name)}' loading='lazy' alt='path of {html.escape(row.drive)}'>"
                   if row.status == "ok" and plot.is_file() else "")
        status = row.status + (" (earlier run)" if row.reused else "")
        cells = [status, f"<a href='{html.escape(row.output)}/'>{html.escape(row.drive)}</a><br>"
                         f"<small>{html.escape(row.kind)}: {html.escape(row.source)}</small>", picture, _drove(row)]
        if scored:
            cells.append(_lines(("t_err {:.2f} %", row.t_err_percent), ("r_err {:.4f} deg/m", row.r_err_deg_per_m)))
        cells.append(_lines(("{:d} frames", row.frames), ("{:.0f} frames/s", row.frames_per_second),
                            ("{:d} unscaled steps", row.unscaled_steps), ("wall {:.1f} s", row.wall_s),
                            ("peak {:.0f} MiB", row.peak_memory_mib)))
        notes = "<br>".join(html.escape(text) for text in (row.error, row.warnings) if text)
        lines.append(f"<tr class='{row.status}'>" + "".join(f"<td>{cell}</td>" for cell in cells)
                     + f"<td class='error'>{notes}</td></tr>")
    counts = ", ".join(f"{totals.get(status, 0)} {status}" for status in ("ok", "failed", "pending"))
    throughput = totals.get("frames_per_second")
    speed = f"; this run: {totals.get('frames_run', 0)} frames, {throughput:.1f} frames/s over the batch" \
        if throughput else ""
    page = (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>flowvo batch</title><style>{_STYLE}</style>"
            f"</head><body><h1>flowvo batch: {len(rows)} drives</h1><p>{counts}{speed}. Summary: "
            "<a href='summary.csv'>summary.csv</a>, <a href='summary.json'>summary.json</a>. Paths: x-z in metres, "
            "ground truth in black where it exists. Drove: path length, duration, mean and top speed (the fastest "
            "1 s), net heading change (left +), from the poses.</p>"
            f"<table>{''.join(lines)}</table></body></html>\n")
    write_text_atomic(out / "index.html", page)
    return out / "index.html"


def _drove(row: DriveSummary) -> str:
    """Distance, duration, speeds and heading change of a completed drive, one per line."""
    if row.path_length_m is None or row.duration_s is None:
        return ""
    return _lines(("{:.1f} m in ", row.path_length_m), ("{:.1f} s", row.duration_s),
                  ("mean {:.1f} m/s", row.mean_speed_mps), ("top {:.1f} m/s", row.top_speed_mps),
                  ("heading {:+.1f} deg", row.heading_change_deg)).replace(" in <br>", " in ", 1)


def _lines(*parts: tuple[str, Any]) -> str:
    """Each (format, value) whose value is known, formatted, one per line."""
    return "<br>".join(spec.format(value) for spec, value in parts if value is not None)
