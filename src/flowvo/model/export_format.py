"""What an exported odometry model says about itself: the names of its input and output, and the JSON
description written beside the model file and into the ONNX metadata. Imports no torch, so an ONNX
Runtime deployment can read it."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from flowvo.model.deployable import DeployableOdometry

FORMAT = "flowvo-deployable-v1"
INPUT_NAME = "flow_px"
OUTPUT_NAME = "motion"
METADATA_KEY = "flowvo"  # ONNX metadata_props key holding the same JSON as the file beside the model
ONNX_OPSET = 17  # supported by torch 2.13's TorchScript-based exporter and ONNX Runtime >= 1.18
ONNX_OPSETS = (11, 20)  # the flip of the mirrored pass needs opset 10+; ONNX Runtime 1.18 reads up to 21
FILE_FORMATS = ("onnx", "torchscript", "slim")  # what ``flowvo export --format`` writes


def export_file_format(out: str, given: str | None) -> str:
    """The format to write ``out`` in: ``given``, else ``onnx`` for a ``.onnx`` name and TorchScript
    otherwise. Raises ValueError (the message) when ``given`` contradicts an ``.onnx`` name either way,
    since a runtime picks its loader by the extension."""
    is_onnx_name = out.lower().endswith(".onnx")
    if given is None:
        return "onnx" if is_onnx_name else "torchscript"
    if is_onnx_name != (given == "onnx"):
        raise ValueError(f"--format {given} does not match the file name {out!r}: ONNX files end in .onnx, "
                         "other formats must not (leave out --format to choose by the extension)")
    return given


def describe(model: DeployableOdometry, training: dict) -> dict:
    """JSON-ready description of an exported model's input and output; ``training`` (checkpoint name,
    normalisation, flow the model was trained on) is added as is."""
    h, w = model.input_hw
    return {
        "format": FORMAT,
        "input": {
            "name": INPUT_NAME, "shape": ["batch", 2 * model.stack, h, w], "dtype": "float32", "units": "px",
            "layout": "K flow fields oldest first, channels (u right, v down) per field, in pixels of the "
                      "network input: the flow centred on the principal point column and resized to (h, w) "
                      "with its values rescaled, as flowvo.model.preprocess.resize_flow returns it",
        },
        "output": {
            "name": OUTPUT_NAME, "shape": ["batch", len(model.output_names)], "dtype": "float32",
            "components": list(model.output_names),
            "units": [name.rsplit("_", 1)[1] for name in model.output_names],
        },
        "head": model.head,
        "stack": model.stack,
        "input_hw": [h, w],
        "symmetric": model.symmetric,
        "flow_note": "flow_size_hw: (H, W) of the flow fields the model was trained on, before centring and "
                     "resizing; compute flow at the scale that gives this width",
        **training,
    }
