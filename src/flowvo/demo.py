"""``flowvo demo``: render a held-out synthetic drive (or take the user's KITTI sequence), run the packaged
model and the classical baseline on it, evaluate both and write the report."""

from __future__ import annotations

from pathlib import Path

from flowvo.errors import FlowvoError
from flowvo.kitti.sequence import KittiSequence
from flowvo.model.checkpoint import packaged_model_path
from flowvo.pipeline import RunOptions, run
from flowvo.report import write_report
from flowvo.synth.dataset import synthesize

DEMO_SEED = 2026  # the packaged model's training worlds use seed 0: this world and path are unseen
DEMO_FRAMES = 900
DEMO_SCALE = 0.5
DEMO_MAX_SPEED_MPS = 15.0  # an urban drive, like the KITTI trajectories the packaged model learned from


def demo(out: str | Path = "runs/demo", data: str | Path | None = None, sequence: str | None = None,
         model: str | Path | None = None, frames: int = DEMO_FRAMES, force: bool = False) -> Path:
    """Run the whole product once and return the report's index.html; ``force`` replaces the runs and the
    report of an earlier demo in ``out`` (the rendered drive is reused when it is the same)."""
    out = Path(out)
    if data is None:
        data, sequence = out / "data", "00"
        synthesize(data, [sequence], seed=DEMO_SEED, frames=frames, scale=DEMO_SCALE, max_speed_mps=DEMO_MAX_SPEED_MPS,
                   force=force)
    elif sequence is None:
        raise FlowvoError("with --data, also give --sequence NN")
    model = Path(model) if model else packaged_model_path()
    runs = [run(RunOptions(data=str(data), sequence=sequence, out=str(out / "learned"), model=str(model),
                           flow_cache=str(out / "flow_cache"), force=force))]
    has_gt = KittiSequence(data, sequence).has_poses
    scale_sources = ("gt", "height") if has_gt else ("height",)
    for source in scale_sources:
        runs.append(run(RunOptions(data=str(data), sequence=sequence, out=str(out / f"classical_{source}"),
                                   method="classical", classical_scale=source, force=force)))
    folders = [out / "learned"] + [out / f"classical_{s}" for s in scale_sources]
    return write_report(folders, out / "report", force)
