"""The versions of flowvo and of the libraries its numbers depend on, as ``run.json`` records them: the
default method's trajectories change with OpenCV's interpolation in its last bits, so a result is only
comparable with another from the same versions."""

from __future__ import annotations

from importlib.metadata import version

import cv2
import numpy as np

from flowvo._version import VERSION as __version__


def library_versions() -> dict[str, str]:
    """flowvo, OpenCV, NumPy and PyTorch versions (PyTorch's as installed, without importing it)."""
    return {"flowvo": __version__, "opencv": cv2.__version__, "numpy": np.__version__, "torch": version("torch")}
