"""flowvo's public Python API (re-exported by :mod:`flowvo`; ``docs/api.md``).

- :class:`Camera` (:mod:`~flowvo.api.camera`): the camera, from numbers or any calibration file;
- :class:`Odometry` (:mod:`~flowvo.api.odometry`): frames pushed one at a time, poses back when final;
- :func:`run` (:mod:`~flowvo.api.whole_drive`): a whole drive (a folder, a video, a bag, an iterable of frames);
- :class:`Trajectory` (:mod:`~flowvo.api.trajectory`) of :class:`Pose` (:mod:`~flowvo.api.pose`): saves KITTI,
  TUM, MCAP and the run folder of ``flowvo run``, and evaluates;
- :func:`evaluate` (:mod:`~flowvo.api.evaluation`): the KITTI metric, ATE, RPE against ground truth;
- :mod:`flowvo.api.rerun`: a live view in Rerun.

Each name is imported when first used, so ``import flowvo.api`` stays light (no torch, no OpenCV).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from flowvo.api.camera import Camera
    from flowvo.api.evaluation import Evaluation, evaluate
    from flowvo.api.odometry import Odometry
    from flowvo.api.pose import Pose
    from flowvo.api.trajectory import Trajectory
    from flowvo.api.whole_drive import run

PUBLIC = {"Camera": "camera", "Odometry": "odometry", "Pose": "pose", "Trajectory": "trajectory", "run": "whole_drive",
          "evaluate": "evaluation", "Evaluation": "evaluation"}
__all__ = ["Camera", "Evaluation", "Odometry", "Pose", "Trajectory", "evaluate", "run"]


def __getattr__(name: str) -> Any:
    if name in PUBLIC:
        return getattr(importlib.import_module(f"flowvo.api.{PUBLIC[name]}"), name)
    raise AttributeError(f"module 'flowvo.api' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(list(globals()) + list(PUBLIC))
