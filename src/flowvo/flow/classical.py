"""Classical CPU flow from OpenCV: DIS at its presets and Farneback.

DeepFlow and TV-L1 live in opencv-contrib, whose wheel replaces opencv-python-headless (both install
the ``cv2`` module); we do not take that swap for two methods that are 10-100x slower than DIS.
"""

from __future__ import annotations

import cv2
import numpy as np

from flowvo.flow.registry import register

DIS_PRESETS = {
    "dis-ultrafast": cv2.DISOPTICAL_FLOW_PRESET_ULTRAFAST,
    "dis-fast": cv2.DISOPTICAL_FLOW_PRESET_FAST,
    "dis-medium": cv2.DISOPTICAL_FLOW_PRESET_MEDIUM,
}


class DisFlow:
    """OpenCV Dense Inverse Search at a named preset."""

    def __init__(self, name: str) -> None:
        self.name = name
        self._dis = cv2.DISOpticalFlow_create(DIS_PRESETS[name])

    def estimate(self, prev: np.ndarray, next: np.ndarray) -> np.ndarray:
        return self._dis.calc(np.ascontiguousarray(prev), np.ascontiguousarray(next), None).astype(np.float32)

    def params(self) -> dict:
        return {"preset": self.name, "opencv": cv2.__version__}


for _preset in DIS_PRESETS:
    register(_preset)(DisFlow)


@register("farneback")
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
