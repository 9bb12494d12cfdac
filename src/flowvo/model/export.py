"""Export a trained odometry network for deployment: ONNX or TorchScript of :class:`DeployableOdometry`
(resized flow in pixels in, motion in metres and radians out), with a JSON file beside it that says what
goes in and comes out. ONNX needs the optional ``onnx`` package (``pip install 'flowvo[export]'``).
"""

from __future__ import annotations

import io
import json
from pathlib import Path

import torch

from flowvo.io.atomic import atomic_open, atomic_path, write_json_atomic
from flowvo.model.checkpoint import load_model
from flowvo.model.deployable import DeployableOdometry
from flowvo.model.export_format import INPUT_NAME, METADATA_KEY, ONNX_OPSET, OUTPUT_NAME, describe
from flowvo.optional import import_optional


def load_for_export(checkpoint: str | Path, symmetric: bool = True) -> tuple[DeployableOdometry, dict]:
    """The deployable module of ``checkpoint`` and its description (:func:`flowvo.model.export_format.describe`)."""
    network, normalization, state = load_model(checkpoint)
    model = DeployableOdometry(network, normalization, symmetric)
    train_config = state.get("train_config", {})
    return model, describe(model, {
        "checkpoint": Path(checkpoint).name,
        "normalization": normalization.to_dict(),
        "flow": {"flow_size_hw": state.get("flow_size_hw"), "flow_method": train_config.get("flow_method"),
                 "flow_scale": train_config.get("flow_scale")},
    })


def export_torchscript(checkpoint: str | Path, out: str | Path, symmetric: bool = True) -> list[Path]:
    """Write ``out`` (traced TorchScript of :class:`DeployableOdometry`, any batch size) and ``out`` +
    ``.json`` (its description); returns both paths."""
    model, description = load_for_export(checkpoint, symmetric)
    description["file_format"] = "torchscript"
    with torch.no_grad():
        traced = torch.jit.trace(model, _example_input(model))
    out = Path(out)
    with atomic_path(out) as tmp:
        traced.save(str(tmp))
    return [out, _write_description(out, description)]


def export_onnx(checkpoint: str | Path, out: str | Path, symmetric: bool = True,
                opset: int = ONNX_OPSET) -> list[Path]:
    """Write ``out`` (ONNX of :class:`DeployableOdometry`, dynamic batch axis, the description also in
    its metadata under ``flowvo``) and ``out`` + ``.json``; returns both paths."""
    onnx = import_optional("onnx", "ONNX export", "export")
    model, description = load_for_export(checkpoint, symmetric)
    description["file_format"] = "onnx"
    buffer = io.BytesIO()
    with torch.no_grad():
        torch.onnx.export(model, (_example_input(model),), buffer, dynamo=False, opset_version=opset,
                          input_names=[INPUT_NAME], output_names=[OUTPUT_NAME],
                          dynamic_axes={INPUT_NAME: {0: "batch"}, OUTPUT_NAME: {0: "batch"}})
    proto = onnx.load_from_string(buffer.getvalue())
    proto.producer_name = "flowvo"
    proto.metadata_props.add(key=METADATA_KEY, value=json.dumps(description))
    onnx.checker.check_model(proto)
    out = Path(out)
    with atomic_open(out, "wb") as handle:
        handle.write(proto.SerializeToString())
    return [out, _write_description(out, description)]


def _example_input(model: DeployableOdometry) -> torch.Tensor:
    return torch.zeros(1, 2 * model.stack, *model.input_hw)


def _write_description(out: Path, description: dict) -> Path:
    path = out.with_name(out.name + ".json")
    write_json_atomic(path, description)
    return path
