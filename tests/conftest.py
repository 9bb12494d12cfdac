"""Shared fixtures: paths into ../shared (skipped cleanly when absent); a private user cache folder."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

SHARED = Path(__file__).resolve().parents[1].parent / "shared"
KITTI_POSES = SHARED / "data" / "kitti" / "poses"
EXAMPLE_RESULTS = SHARED / "data" / "kitti" / "example_results"
REAL_CLIPS = SHARED / "data" / "real" / "kitti_clips"


@pytest.fixture
def kitti_poses_dir() -> Path:
    if not KITTI_POSES.is_dir():
        pytest.skip(f"shared KITTI poses not found at {KITTI_POSES}")
    return KITTI_POSES


@pytest.fixture
def example_results_dir() -> Path:
    if not EXAMPLE_RESULTS.is_dir():
        pytest.skip(f"shared example results not found at {EXAMPLE_RESULTS}")
    return EXAMPLE_RESULTS


@pytest.fixture(scope="session")
def real_clips() -> Path:
    """The real KITTI clips' root (validation data, never trained on)."""
    if not (REAL_CLIPS / "sequences" / "06" / "image_0").is_dir():
        pytest.skip(f"real KITTI clips not found at {REAL_CLIPS}")
    return REAL_CLIPS


@pytest.fixture(scope="session")
def clip_06(real_clips) -> Path:
    """Real clip 06's sequence folder (50 frames, 59 m, straight suburban road)."""
    return real_clips / "sequences" / "06"


@pytest.fixture(autouse=True, scope="session")
def single_torch_thread():
    """One intra-op thread per test process: on a busy 2-core machine, spinning OpenMP threads make small
    networks 10x slower; results do not depend on the thread count."""
    import torch

    torch.set_num_threads(1)


@pytest.fixture(autouse=True, scope="session")
def private_user_cache(tmp_path_factory):
    """Default flow caches go to $XDG_CACHE_HOME/flowvo: point it at a temporary folder, so tests never
    write into the real ~/.cache (subprocesses inherit it)."""
    previous = os.environ.get("XDG_CACHE_HOME")
    os.environ["XDG_CACHE_HOME"] = str(tmp_path_factory.mktemp("xdg_cache"))
    yield Path(os.environ["XDG_CACHE_HOME"])
    if previous is None:
        del os.environ["XDG_CACHE_HOME"]
    else:
        os.environ["XDG_CACHE_HOME"] = previous
