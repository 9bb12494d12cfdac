"""Export the network for deployment: ``flowvo export``."""

from __future__ import annotations

import argparse
from pathlib import Path

from flowvo.cli.arguments import bounded, force_flag
from flowvo.errors import FlowvoError


def command(args: argparse.Namespace) -> int:
    from flowvo.io.outputs import prepare_output_file
    from flowvo.model.checkpoint import packaged_model_path, read_checkpoint, write_slim_checkpoint
    from flowvo.model.export import export_onnx, export_torchscript
    from flowvo.model.export_format import export_file_format

    try:
        file_format = export_file_format(args.out, args.format)
    except ValueError as error:
        raise FlowvoError(str(error)) from None
    model = args.model or packaged_model_path()
    read_checkpoint(model)  # a clear error for a missing or foreign file before anything is written
    out = Path(args.out)
    if out.resolve() == Path(model).resolve():
        raise FlowvoError("--out is the --model file itself; write the export elsewhere", out)
    extra = [out.with_name(out.name + ".json")] if file_format != "slim" else []  # the description
    for target in (out, *extra):
        prepare_output_file(target, args.force)
    if file_format == "slim":
        written = [write_slim_checkpoint(model, args.out)]
    elif file_format == "onnx":
        written = export_onnx(model, args.out, not args.no_symmetric, args.opset)
    else:
        written = export_torchscript(model, args.out, not args.no_symmetric)
    for path in written:
        print(f"wrote {path}")
    return 0


def add_parser(sub: argparse._SubParsersAction) -> None:
    from flowvo.model.export_format import FILE_FORMATS, ONNX_OPSET, ONNX_OPSETS

    p = sub.add_parser("export", help="export a checkpoint: ONNX or TorchScript (+ JSON), or a slim float16 checkpoint")
    p.add_argument("--model", help="checkpoint (default: the packaged model)")
    p.add_argument("--out", required=True, help="output file, e.g. model.onnx, model.ts or default.pt")
    p.add_argument("--format", choices=FILE_FORMATS,
                   help="default: onnx for an .onnx --out, else torchscript. onnx / torchscript: flow "
                        "(B, 2K, h, w) in pixels of the network input -> motion (B, D) in m and rad, "
                        "described in OUT.json (onnx needs: pip install 'flowvo[export]'); "
                        "slim: float16 weights + config + normalisation, runnable by flowvo run (not resumable)")
    p.add_argument("--no-symmetric", action="store_true",
                   help="onnx / torchscript: run only the direct pass, not its average with the mirrored one "
                        "(half the network cost; keeps the small constant heading offset the average cancels)")
    p.add_argument("--opset", type=bounded(int, *ONNX_OPSETS), default=ONNX_OPSET,
                   help=f"onnx: opset version ({ONNX_OPSETS[0]}..{ONNX_OPSETS[1]})")
    force_flag(p, "an existing --out file")
    p.set_defaults(func=command)
