"""Checking ``--device`` before any work: a missing GPU is one clear line, not a CUDA traceback later."""

from __future__ import annotations

from flowvo.errors import FlowvoError


def check_device(name: str) -> str:
    """``name`` (``cpu``, ``cuda``, ``cuda:N``) if this machine can run torch there; else a FlowvoError."""
    import torch

    try:
        device = torch.device(name)
    except (RuntimeError, TypeError):
        raise FlowvoError(f"--device {name!r} is not a device name; use cpu, cuda or cuda:N") from None
    if device.type == "cpu":
        return name
    if device.type != "cuda":
        raise FlowvoError(f"--device {name}: flowvo runs on cpu or cuda only")
    if not torch.cuda.is_available():
        raise FlowvoError(f"--device {name}: no CUDA GPU is usable here (torch {torch.__version__}, "
                          f"CUDA build: {torch.version.cuda or 'none'}); use --device cpu")
    if device.index is not None and device.index >= torch.cuda.device_count():
        raise FlowvoError(f"--device {name}: this machine has {torch.cuda.device_count()} CUDA device(s)")
    return name
