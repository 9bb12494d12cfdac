"""Checkpoints: model, optimiser, scheduler, epoch, configuration and normalisation in one file.

Loaded with ``torch.load(..., weights_only=True)``; a checkpoint of another architecture or input size
is refused with a message naming the difference.
"""

from __future__ import annotations

from dataclasses import asdict
from importlib import resources
from pathlib import Path

import torch

from flowvo.atomic import atomic_path
from flowvo.errors import FlowvoError
from flowvo.model.config import ModelConfig
from flowvo.model.data import Normalization
from flowvo.model.network import OdometryNet

FORMAT = "flowvo-odometry-v1"


def packaged_model_path() -> Path:
    """The default model shipped inside the package (see README: how it was trained)."""
    path = Path(str(resources.files("flowvo") / "models" / "default.pt"))
    if not path.is_file():
        raise FlowvoError("the packaged model is missing; train one (README, 'The packaged model')", path)
    return path


def save_checkpoint(path: str | Path, state: dict) -> None:
    """Write ``state`` (plain containers and tensors) atomically."""
    with atomic_path(path) as tmp:
        torch.save({"format": FORMAT, **state}, tmp)


def read_checkpoint(path: str | Path) -> dict:
    """The raw checkpoint dictionary, validated to be a flowvo odometry checkpoint."""
    path = Path(path)
    if not path.is_file():
        raise FlowvoError("model checkpoint not found", path)
    try:
        state = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as error:  # torch raises several types for corrupt or foreign files
        raise FlowvoError(f"cannot read as a PyTorch checkpoint ({type(error).__name__})", path) from None
    if not isinstance(state, dict) or state.get("format") != FORMAT:
        raise FlowvoError(f"not a flowvo odometry checkpoint (expected format {FORMAT})", path)
    return state


def model_config_of(state: dict) -> ModelConfig:
    data = dict(state["model_config"])
    return ModelConfig(**data)


def check_compatible(state: dict, expected: ModelConfig, path: str | Path) -> None:
    """Refuse a checkpoint whose architecture or input size differs from ``expected``."""
    stored = asdict(model_config_of(state))
    wanted = asdict(expected)
    differences = [f"{k}={stored[k]!r} (expected {wanted[k]!r})" for k in wanted if stored[k] != wanted[k]]
    if differences:
        raise FlowvoError("checkpoint has a different architecture: " + ", ".join(differences), path)


def load_model(path: str | Path, expected: ModelConfig | None = None) -> tuple[OdometryNet, Normalization, dict]:
    """The network (eval mode), its normalisation and the raw checkpoint."""
    state = read_checkpoint(path)
    config = model_config_of(state)
    if expected is not None:
        check_compatible(state, expected, path)
    model = OdometryNet(config)
    try:
        model.load_state_dict(state["model_state"])
    except RuntimeError:
        raise FlowvoError("weights do not fit the architecture stored in the checkpoint", path) from None
    return model.eval(), Normalization.from_dict(state["normalization"]), state


def write_slim_checkpoint(source: str | Path, target: str | Path) -> Path:
    """A deployable checkpoint: float16 weights, configuration, normalisation and training history;
    no optimiser, scheduler or RNG state (so it cannot be resumed, only run)."""
    state = read_checkpoint(source)
    keep = ("model_config", "train_config", "normalization", "flow_size_hw", "history", "epoch", "best")
    slim = {key: state[key] for key in keep if key in state}
    slim["model_state"] = {k: v.half() if v.is_floating_point() else v for k, v in state["model_state"].items()}
    save_checkpoint(target, slim)
    return Path(target)
