"""A rolling shutter's share of the road's baseline.

A rolling shutter exposes a frame's rows one after another, top to bottom, over its readout time. A road point seen
in row ``r1`` of a road key frame and in row ``r2`` of the current frame (of ``R`` rows) was therefore seen
``(r2 - r1) / R * readout`` later or earlier than the frames' own interval says. The near road moves down the frame
between two frames, so it is seen over a longer baseline than the frames' interval: with the interval's, its
triangulated depth comes out short by that share, the road plane nearer and every length long (KITTI's synthetic camera
read out over 30 ms at 10 Hz, seeds 3-6: paths +2.3 to +3.8 %, t_err 2.98 %; with each point's baseline 0.47 %, its
global shutter 0.39 %).

At a constant velocity over the span, a point triangulated from two camera centres a baseline ``b`` apart lies at
``b`` over the assumed baseline times its triangulated distance from the first centre. The first centre itself lies
``r1 / R * readout`` of the motion past the key frame's: along the direction of travel, which moves a point along the
road's plane and leaves the plane's distance as it is. Rotation within the readout is left out (a car turning at 10
degrees a second turns 0.3 degrees within a 30 ms readout).

Rows of the frames as they come (a lens's distortion not undone: the sensor's rows); times in seconds.
"""

from __future__ import annotations

import numpy as np

from flowvo.errors import FlowvoError

INTERVAL_TOLERANCE = 0.05  # the first two frames' timestamps may fall this share short of the frame interval (jitter)


def baseline_shares(rows_key_px: np.ndarray, rows_current_px: np.ndarray, frame_rows: int, readout_s: float,
                    span_s: float) -> np.ndarray:
    """Each road point's baseline over the span's (N,): the point seen in row ``rows_key_px`` of the key frame and
    ``rows_current_px`` of the current frame (N,), frames of ``frame_rows`` rows read out over ``readout_s`` seconds,
    ``span_s`` seconds apart (first row to first row). All ones for a global shutter (``readout_s`` 0)."""
    return 1.0 + (np.asarray(rows_current_px, np.float64) - rows_key_px) * (readout_s / (frame_rows * span_s))


def check_readout_within(readout_ms: float, interval_s: float) -> None:
    """Refuse a readout time (milliseconds) longer than the first two frames' ``interval_s`` (seconds): a rolling
    shutter reads a frame out within the frame interval (one line, naming ``--readout-ms``)."""
    if readout_ms / 1000.0 > interval_s * (1.0 + INTERVAL_TOLERANCE):
        raise FlowvoError(f"--readout-ms {readout_ms:g}: longer than the {interval_s * 1000.0:.1f} ms between the "
                          "first two frames; a rolling shutter reads a frame out within the frame interval")
