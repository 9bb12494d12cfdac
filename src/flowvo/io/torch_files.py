"""Reading PyTorch files: the one guarded ``torch.load`` (tensors and plain containers only, never code)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import torch

from flowvo.errors import FlowvoError


def load_torch_file(path: str | Path) -> Any:
    """The content of a PyTorch file, loaded on the CPU with ``weights_only=True``; a one-line error naming
    the file when it is missing or not a PyTorch file."""
    path = Path(path)
    if not path.is_file():
        raise FlowvoError("file not found", path)
    try:
        return torch.load(path, map_location="cpu", weights_only=True)
    except Exception as error:  # torch raises several types for corrupt or foreign files
        raise FlowvoError(f"cannot read as a PyTorch checkpoint ({type(error).__name__})", path) from None
