"""Numbers in text files as the files' formats define them: Python's ``float`` also reads ``1_0`` (as 10)
and ``0_9`` (as 9.0), which no calibration, pose or times file means."""

from __future__ import annotations


def parse_float(text: str) -> float:
    """``float(text)``, refusing digit-group underscores; raises ValueError like ``float``."""
    if "_" in text:
        raise ValueError(f"not a number: {text!r}")
    return float(text)
