"""Export a trained odometry network for deployment as TorchScript (ONNX would need the onnx package,
which flowvo does not depend on). The normalisation travels in a JSON file beside the model."""

from __future__ import annotations

from pathlib import Path

import torch

from flowvo.atomic import atomic_path, write_json_atomic
from flowvo.model.checkpoint import load_model


def export_torchscript(checkpoint: str | Path, out: str | Path) -> list[Path]:
    """Write ``out`` (TorchScript, input (B, 2K, H, W) flow / flow_std_px -> normalised motion) and
    ``out`` + ``.json`` (input size, head, normalisation); returns both paths."""
    model, normalization, state = load_model(checkpoint)
    example = torch.zeros(1, 2 * model.config.stack, *model.config.input_hw)
    with torch.no_grad():
        traced = torch.jit.trace(model, example)
    out = Path(out)
    with atomic_path(out) as tmp:
        traced.save(str(tmp))
    meta = out.with_name(out.name + ".json")
    write_json_atomic(meta, {"model_config": state["model_config"], "normalization": normalization.to_dict(),
                             "flow_size_hw": state.get("flow_size_hw"),
                             "usage": "outputs * target_std + target_mean = motion (m, rad)"})
    return [out, meta]
