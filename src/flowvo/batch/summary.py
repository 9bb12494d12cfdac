"""The fleet summary files: ``OUT/summary.json`` (batch totals and one record per drive, with the settings
each ran with) and ``OUT/summary.csv`` (one line per drive, the same fields less the settings)."""

from __future__ import annotations

import csv
import dataclasses
import io
import json
from pathlib import Path
from typing import Any

from flowvo._version import VERSION as __version__
from flowvo.batch.record import STATUSES, DriveSummary
from flowvo.errors import FlowvoError
from flowvo.io.atomic import write_json_atomic, write_text_atomic

CSV_FIELDS = tuple(f.name for f in dataclasses.fields(DriveSummary) if f.name != "settings")


def batch_totals(rows: list[DriveSummary], frames_run: int, wall_s: float, backend: str) -> dict[str, Any]:
    """Counts per status, frames of the completed drives, and this run's throughput: ``frames_run`` frames
    computed in ``wall_s`` seconds of the whole batch (start-up and every worker included)."""
    totals: dict[str, Any] = {"flowvo": __version__, "backend": backend, "drives": len(rows)}
    totals.update({status: sum(row.status == status for row in rows) for status in STATUSES})
    totals["reused"] = sum(row.reused for row in rows)
    totals["frames"] = sum(row.frames or 0 for row in rows if row.status == "ok")
    totals["frames_run"] = frames_run
    totals["wall_s"] = round(wall_s, 3)
    totals["frames_per_second"] = round(frames_run / wall_s, 2) if wall_s > 0 and frames_run else None
    return totals


def write_summary(out: str | Path, rows: list[DriveSummary], totals: dict[str, Any]) -> None:
    """Write summary.json and summary.csv into ``out`` (each atomically)."""
    out = Path(out)
    write_json_atomic(out / "summary.json", {"batch": totals, "drives": [row.as_dict() for row in rows]})
    table = io.StringIO()
    writer = csv.DictWriter(table, fieldnames=CSV_FIELDS, extrasaction="ignore", lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({k: "" if v is None else v for k, v in row.as_dict().items()})
    write_text_atomic(out / "summary.csv", table.getvalue())


def read_summary(out: str | Path) -> dict[str, DriveSummary] | None:
    """The drive records of the summary.json in ``out`` by drive name; None when there is none."""
    path = Path(out) / "summary.json"
    if not path.is_file():
        return None
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        rows = [DriveSummary.from_dict(record) for record in data["drives"]]
    except (UnicodeDecodeError, json.JSONDecodeError, KeyError, TypeError):
        raise FlowvoError("is not a flowvo batch summary (damaged?); move it away to start the batch afresh",
                          path) from None
    return {row.drive: row for row in rows}
