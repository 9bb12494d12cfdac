"""Classical CPU flow from OpenCV: DIS at its presets and Farneback.

DeepFlow and TV-L1 live in opencv-contrib, whose wheel replaces opencv-python-headless (both install
the ``cv2`` module); we do not take that swap for two methods that are 10-100x slower than DIS.
"""

from __future__ import annotations

import cv2
import numpy as np

# name: (OpenCV preset, settings that differ from the preset's). The presets stop one pyramid level above
# the input (finest scale 1: flow estimated at half resolution, then upsampled); the "-fine" variants go down
# to the input resolution, which halves the spread of road-plane scale estimates on real KITTI.
# "dis-road", the default method's road flow: "dis-medium-fine" with patches every 4 px instead of 3 and one
# iteration of the variational refinement (a smoothness energy over the field) instead of five. On the road
# crop of the real clips at 620 px it takes 2.9 instead of 5.5 ms, with the road step lengths as good (against
# the truth, with the road predicted as the default method does: median -1.6 % against -1.8 %, inter-quartile
# 5.0 % against 4.7 %). Without any refinement, steps at walking pace came out 16 % long (clip 07's start).
# Its patches descend 12 gradient steps, not the preset's 25: the current frame is warped onto the predicted road,
# so each patch starts near its answer (0.6 ms less a step; real clips 03 / 03 at 5 Hz / 01 / 06 / 07 0.91 / 1.01 /
# 1.06 / 0.80 / 1.29 -> 0.95 / 0.91 / 0.92 / 0.79 / 1.19 %, synthetic replays 0.895 -> 0.880 % (docs/results.md);
# 8 steps as good on KITTI but took a pitch on the real dash-cam and read it 14 % slower; 4 steps: clip 01 2.4 %).
DIS_PRESETS: dict[str, tuple[int, dict[str, int]]] = {
    "dis-ultrafast": (cv2.DISOPTICAL_FLOW_PRESET_ULTRAFAST, {}),
    "dis-fast": (cv2.DISOPTICAL_FLOW_PRESET_FAST, {}),
    "dis-medium": (cv2.DISOPTICAL_FLOW_PRESET_MEDIUM, {}),
    "dis-fast-fine": (cv2.DISOPTICAL_FLOW_PRESET_FAST, {"FinestScale": 0}),
    "dis-medium-fine": (cv2.DISOPTICAL_FLOW_PRESET_MEDIUM, {"FinestScale": 0}),
    "dis-road": (cv2.DISOPTICAL_FLOW_PRESET_MEDIUM,
                 {"FinestScale": 0, "PatchStride": 4, "VariationalRefinementIterations": 1,
                  "GradientDescentIterations": 12}),
}


class DisFlow:
    """OpenCV Dense Inverse Search at a named preset (with its settings, :data:`DIS_PRESETS`)."""

    def __init__(self, name: str) -> None:
        self.name = name
        preset, settings = DIS_PRESETS[name]
        self._dis = cv2.DISOpticalFlow_create(preset)
        for setting, value in settings.items():
            getattr(self._dis, f"set{setting}")(value)

    def estimate(self, prev: np.ndarray, next: np.ndarray) -> np.ndarray:
        flow = self._dis.calc(np.ascontiguousarray(prev), np.ascontiguousarray(next), None)
        return flow.astype(np.float32, copy=False)  # DIS gives float32: no copy

    def params(self) -> dict:
        return {"preset": self.name, "opencv": cv2.__version__}


class FarnebackFlow:
    """OpenCV Farneback polynomial-expansion flow (5 levels, 15 px window)."""

    SETTINGS = {"pyr_scale": 0.5, "levels": 5, "winsize": 15, "iterations": 3, "poly_n": 5, "poly_sigma": 1.2}

    def __init__(self, name: str = "farneback") -> None:
        self.name = name

    def estimate(self, prev: np.ndarray, next: np.ndarray) -> np.ndarray:
        flow = cv2.calcOpticalFlowFarneback(
            np.ascontiguousarray(prev), np.ascontiguousarray(next), None, flags=0, **self.SETTINGS
        )
        return flow.astype(np.float32)

    def params(self) -> dict:
        return {**self.SETTINGS, "opencv": cv2.__version__}
