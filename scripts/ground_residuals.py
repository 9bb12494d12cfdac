"""Print where the ground the road grid sees stands off the road: the median residual of every road point from the
trusted road plane it was fitted with, per mille of the camera height (negative: above the plane), by depth and by
distance sideways in camera heights, over one run of the default method (docs/results.md, the ground beside the
road).

Usage: python scripts/ground_residuals.py DATA SEQUENCE OUT_DIR [flowvo run options...]
(runs `flowvo run --data DATA --sequence SEQUENCE --out OUT_DIR`; "." marks a cell with fewer than 100 points)
"""

import sys

import numpy as np

import flowvo.odometry.road_length as road_length
from flowvo.cli import main
from flowvo.odometry.road_plane import RoadPlane
from flowvo.odometry.road_profile import RoadProfile, road_residuals

DEPTH_BANDS_H = ((4, 7), (7, 10), (10, 20))
SIDE_EDGES_H = np.arange(-4.0, 4.01, 0.5)
MIN_POINTS = 100


class RecordingProfile(RoadProfile):
    """The run's road profile, keeping every trusted plane's points as (depth, sideways, residual) in heights."""

    seen: list[np.ndarray] = []

    def observe(self, points: np.ndarray, plane: RoadPlane) -> None:
        super().observe(points, plane)
        if plane.distance > 0 and len(points):
            self.seen.append(np.c_[points[:, 2] / plane.distance, points[:, 0] / plane.distance,
                                   road_residuals(points, plane)])


def main_table(argv: list[str]) -> int:
    data, sequence, out = argv[:3]
    road_length.RoadProfile = RecordingProfile
    code = main(["-q", "run", "--data", data, "--sequence", sequence, "--out", out, "--force", *argv[3:]])
    if code or not RecordingProfile.seen:
        return code or 1
    points = np.concatenate(RecordingProfile.seen)
    print("| depth (heights) | " + " | ".join(f"{edge:+g}" for edge in SIDE_EDGES_H[:-1]) + " |")
    print("| --- " * len(SIDE_EDGES_H) + "|")
    for near, far in DEPTH_BANDS_H:
        cells = []
        for low, high in zip(SIDE_EDGES_H[:-1], SIDE_EDGES_H[1:], strict=True):
            inside = (points[:, 0] >= near) & (points[:, 0] < far) & (points[:, 1] >= low) & (points[:, 1] < high)
            cells.append(f"{1000 * np.median(points[inside, 2]):+.0f}" if inside.sum() >= MIN_POINTS else ".")
        print(f"| {near}-{far} | " + " | ".join(cells) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main_table(sys.argv[1:]))
