"""The per-frame stages a stream times, and which of them each method has (from the method table)."""

from __future__ import annotations

STAGES = ("image_read", "flow", "network", "geometry", "window", "chaining")


def stage_seconds_text(method: str, stage: str, seconds: float | None) -> str:
    """Seconds per frame to 4 decimals, or "-" for a stage the method does not have."""
    from flowvo.methods import METHODS

    known = METHODS.get(method)
    if seconds is None or stage not in (known.stages if known else STAGES):
        return "-"
    return f"{seconds:.4f}"
