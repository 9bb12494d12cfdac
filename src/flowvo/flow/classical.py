"""Classical CPU flow from OpenCV: DIS at its presets and Farneback.

DeepFlow and TV-L1 live in opencv-contrib, whose wheel replaces opencv-python-headless (both install
the ``cv2`` module); we do not take that swap for two methods that are 10-100x slower than DIS.
"""

from __future__ import annotations

import cv2
import numpy as np

# name: (OpenCV preset, finest pyramid level or None for the preset's). The presets stop one level above
# the input (finest level 1: flow estimated at half resolution, then upsampled); the "-fine" variants
# go down to the input resolution, which halves the spread of road-plane scale estimates on real KITTI.
DIS_PRESETS = {
    "dis-ultrafast": (cv2.DISOPTICAL_FLOW_PRESET_ULTRAFAST, None),
    "dis-fast": (cv2.DISOPTICAL_FLOW_PRESET_FAST, None),
    "dis-medium": (cv2.DISOPTICAL_FLOW_PRESET_MEDIUM, None),
    "dis-fast-fine": (cv2.DISOPTICAL_FLOW_PRESET_FAST, 0),
    "dis-medium-fine": (cv2.DISOPTICAL_FLOW_PRESET_MEDIUM, 0),
}


class DisFlow:
    """OpenCV Dense Inverse Search at a named preset (and finest level)."""

    def __init__(self, name: str) -> None:
        self.name = name
        preset, finest_level = DIS_PRESETS[name]
        self._dis = cv2.DISOpticalFlow_create(preset)
        if finest_level is not None:
            self._dis.setFinestScale(finest_level)

    def estimate(self, prev: np.ndarray, next: np.ndarray) -> np.ndarray:
        return self._dis.calc(np.ascontiguousarray(prev), np.ascontiguousarray(next), None).astype(np.float32)

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
