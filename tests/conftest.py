"""Shared fixtures: paths into ../shared (skipped cleanly when absent)."""

from __future__ import annotations

from pathlib import Path

import pytest

SHARED = Path(__file__).resolve().parents[1].parent / "shared"
KITTI_POSES = SHARED / "data" / "kitti" / "poses"
EXAMPLE_RESULTS = SHARED / "data" / "kitti" / "example_results"


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


@pytest.fixture(autouse=True, scope="session")
def single_torch_thread():
    """One intra-op thread per test process: on a busy 2-core machine, spinning OpenMP threads make small
    networks 10x slower; results do not depend on the thread count."""
    import torch

    torch.set_num_threads(1)
