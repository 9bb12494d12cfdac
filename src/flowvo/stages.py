"""Which per-frame stages each odometry method has (one rule for run, bench and the report)."""

from __future__ import annotations

STAGES = ("image_read", "flow", "network", "geometry", "chaining")
METHOD_STAGES = {
    "flowvo": ("image_read", "flow", "geometry", "chaining"),  # its rare network fallback counts as geometry
    "flowvo-geometry": ("image_read", "flow", "geometry", "chaining"),
    "cnn": ("image_read", "flow", "network", "chaining"),
    "classical": ("image_read", "flow", "geometry", "chaining"),
}


def stage_seconds_text(method: str, stage: str, seconds: float | None) -> str:
    """Seconds per frame to 4 decimals, or "-" for a stage the method does not have."""
    if seconds is None or stage not in METHOD_STAGES.get(method, STAGES):
        return "-"
    return f"{seconds:.4f}"
