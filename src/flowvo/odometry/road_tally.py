"""How a drive's candidate road planes fared, and the camera's pitch and roll they agree on (the mounting taken
from the drive, :mod:`flowvo.odometry.road_length`). Angles in degrees; planes in the road-levelled camera frame.
"""

from __future__ import annotations

import numpy as np

from flowvo.odometry.road_plane import MAX_ROAD_TILT_RAD, RoadPlane, is_below_camera

MIN_TILTED_FOR_HINT = 20  # candidate planes refused as tilted before they say anything of the mounting
MIN_HINT_DEG = 1.0  # the candidates' median pitch (or roll) must be this far from the one given before it is taken
# (see flowvo.odometry.road_length): real KITTI's level camera reads 0.0-1.0 degrees of pitch and 0.2-0.7 of roll, and
# a mounting taken must not be followed by another
MAX_ALIKE_SPREAD_DEG = 2.0  # the candidates' pitches (or rolls) must lean alike (inter-quartile range below this) for
# their median to be the mounting: the real dash-cam's scatter over 4.4 degrees (-6.5 to -2.1), and their median (-3.4,
# the horizon says -1.7) halved its speed when given as its pitch ([dashcam.md](dashcam.md))


def _spread_deg(angles_deg: list[float]) -> float | None:
    """The inter-quartile range of ``angles_deg`` (degrees); None before ``MIN_TILTED_FOR_HINT`` of them."""
    if len(angles_deg) < MIN_TILTED_FOR_HINT:
        return None
    low, high = np.percentile(angles_deg, [25, 75])
    return float(high - low)


def _alike_median_deg(angles_deg: list[float]) -> float:
    """The median of ``angles_deg`` (degrees) where they lean alike by ``MIN_HINT_DEG`` or more, else 0."""
    spread = _spread_deg(angles_deg)
    median = float(np.median(angles_deg))
    return median if spread is not None and spread < MAX_ALIKE_SPREAD_DEG and abs(median) >= MIN_HINT_DEG else 0.0


class RoadPlaneTally:
    """How the drive's candidate road planes fared: trusted, or refused as tilted, and the pitch and roll of every
    candidate (degrees, its normal's angle from the road's normal about the camera's x axis, positive when the
    camera looks further down than it was said to, and about its z axis, positive when the camera's right side
    is lower than it was said to be: :func:`flowvo.camera.mounting_rotation`). A camera pitched down or rolled but
    taken for level sees every road plane tilted by its mounting: most planes refused, their pitches and rolls
    alike. The mounting is estimated from all candidates, not from the refused ones alone (those lean by more than
    the gate by construction: advice from them never settled). Once a mounting is taken, a plane through the camera
    (:func:`flowvo.odometry.road_plane.is_below_camera`: the rays of one grid row fit it at any depth) is counted but
    leaves the pitches and rolls alone: it leans however its row does, and such planes kept the candidates' spread
    over the gate after a wrong take, so it was never corrected (a camera pitched 5 degrees up, run as if level, took
    -8.8 degrees and read 16.7 % instead of 3.3: docs/synthetic_cameras.md). Before any take they count: on a road
    that is no plane to the method (the real dash-cam's, 40 of its 195 candidates through the camera) they are part
    of the scatter that keeps a mounting from being taken at all (left out there too, it took -2.3 degrees and read
    15 m/s instead of 31, the lane dashes' 24-31)."""

    def __init__(self) -> None:
        self.trusted = 0
        self.refused_as_tilted = 0
        self.pitches_deg: list[float] = []
        self.rolls_deg: list[float] = []
        self._since = (0, 0)  # (trusted, refused as tilted) when the pitches were last cleared (:meth:`restart`)
        self._taken = False  # a mounting was taken from the drive (:meth:`restart`)

    def add(self, plane: RoadPlane, trusted: bool, max_tilt_rad: float = MAX_ROAD_TILT_RAD) -> None:
        """Count a candidate plane (level frame) and whether it was trusted."""
        self.trusted += bool(trusted)
        self.refused_as_tilted += bool(not trusted and plane.tilt_rad > max_tilt_rad)
        if self._taken and not is_below_camera(plane):
            return
        self.pitches_deg.append(float(np.degrees(np.arctan2(plane.normal[2], plane.normal[1]))))
        self.rolls_deg.append(float(np.degrees(np.arctan2(plane.normal[0], plane.normal[1]))))

    def restart(self) -> None:
        """The camera's mounting changed (taken from the drive): it is estimated afresh from the candidates after
        now; the counts go on."""
        self.pitches_deg, self.rolls_deg = [], []
        self._since = (self.trusted, self.refused_as_tilted)
        self._taken = True

    def mounting_deg(self) -> tuple[float, float] | None:
        """The camera's pitch and roll relative to the ones given (degrees), the medians over every candidate plane;
        None before ``MIN_TILTED_FOR_HINT`` candidates."""
        if len(self.pitches_deg) < MIN_TILTED_FOR_HINT:
            return None
        return float(np.median(self.pitches_deg)), float(np.median(self.rolls_deg))

    def pitch_spread_deg(self) -> float | None:
        """The inter-quartile range of the candidates' pitches (degrees); None before ``MIN_TILTED_FOR_HINT``."""
        return _spread_deg(self.pitches_deg)

    def mounting_pending(self) -> bool:
        """Whether the candidate planes so far say the camera may be mounted otherwise than given, too few yet to
        take it from: no mounting taken, most candidates refused as tilted, fewer than ``MIN_TILTED_FOR_HINT`` of
        them (a drive's first seconds with its pitch not told: the road is seen, through a mounting not known yet)."""
        return not self._taken and self.trusted < self.refused_as_tilted < MIN_TILTED_FOR_HINT

    def mounting_hint_deg(self) -> tuple[float, float] | None:
        """The pitch and roll to add to the ones given (degrees) when most candidate planes were refused as tilted,
        at least ``MIN_TILTED_FOR_HINT`` of them, or, once a mounting was taken from the drive, after as many
        candidates whatever became of them (as many below the camera: class docstring): each the candidates' median
        where they lean alike in it (``MAX_ALIKE_SPREAD_DEG``) by ``MIN_HINT_DEG`` or more, else 0; None when neither
        is (with the mounting taken, the candidates after it centre on the road and nothing more is taken). Planes
        refused but scattered say the road's flow is poor, not the mounting. A mounting taken is the drive's estimate,
        not the user's: where a stretch of road rolled against the camera (a rendered world's, synthetic 08: 2.7
        degrees) gave it, the road after the stretch leans back by less than the gate, its planes trusted, and takes it
        back all the same."""
        trusted, refused = self.trusted - self._since[0], self.refused_as_tilted - self._since[1]
        if self._taken:
            if trusted + refused < MIN_TILTED_FOR_HINT:
                return None
        elif refused < MIN_TILTED_FOR_HINT or refused <= trusted:  # the counts first: asked after every candidate
            return None
        hint = tuple(_alike_median_deg(angles) for angles in (self.pitches_deg, self.rolls_deg))
        return None if hint == (0.0, 0.0) else hint

    def record(self) -> dict:
        """The tally as ``run.json`` records it."""
        mounting = self.mounting_deg()
        return {"trusted": self.trusted, "refused_as_tilted": self.refused_as_tilted,
                "candidates_median_pitch_deg": None if mounting is None else round(mounting[0], 2),
                "candidates_median_roll_deg": None if mounting is None else round(mounting[1], 2),
                "candidates_pitch_spread_deg": None if mounting is None else round(self.pitch_spread_deg(), 2)}
