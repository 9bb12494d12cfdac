"""Checkpoints: model, optimiser, scheduler, epoch, configuration and normalisation in one file.

Loaded with ``torch.load(..., weights_only=True)``; a checkpoint of another architecture or input size
is refused with a message naming the difference.
"""

from __future__ import annotations

import math
from dataclasses import asdict, fields
from importlib import resources
from pathlib import Path

import torch

from flowvo.errors import FlowvoError
from flowvo.io.atomic import atomic_path
from flowvo.io.torch_files import load_torch_file
from flowvo.model.config import ModelConfig
from flowvo.model.network import OdometryNet
from flowvo.model.preprocess import Normalization

FORMAT = "flowvo-odometry-v1"
RUNNABLE_KEYS = ("model_config", "normalization", "model_state")
RESUMABLE_KEYS = ("optimizer_state", "scheduler_state", "epoch", "best", "bad_epochs", "history", "rng_state")


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
    state = load_torch_file(path)
    if not isinstance(state, dict) or state.get("format") != FORMAT:
        raise FlowvoError(f"not a flowvo odometry checkpoint (expected format {FORMAT})", path)
    missing = [key for key in RUNNABLE_KEYS if not isinstance(state.get(key), dict)]
    if missing:
        raise FlowvoError(f"checkpoint lacks {', '.join(missing)}: damaged or written by another tool", path)
    _normalization_of(state, model_config_of(state, path).outputs, path)
    return state


def read_resumable_checkpoint(path: str | Path) -> dict:
    """A checkpoint that holds everything training needs to continue (not a slim or exported one)."""
    state = read_checkpoint(path)
    missing = [key for key in RESUMABLE_KEYS if key not in state]
    if missing:
        raise FlowvoError(f"cannot resume from this checkpoint: it lacks {', '.join(missing)} (a slim "
                          "checkpoint can be run, not resumed)", path)
    if not isinstance(state.get("train_config"), dict):
        raise FlowvoError("cannot resume: the checkpoint records no training configuration", path)
    return state


def model_config_of(state: dict, path: str | Path | None = None) -> ModelConfig:
    """The checkpoint's architecture; unknown or invalid options are refused (never silently dropped)."""
    data = dict(state["model_config"])
    unknown = sorted(set(data) - {f.name for f in fields(ModelConfig)})
    if unknown:
        raise FlowvoError(f"checkpoint's model_config has option(s) this flowvo does not know: {', '.join(unknown)} "
                          "(written by a newer flowvo?)", path)
    try:
        return ModelConfig(**data)
    except FlowvoError as error:
        raise FlowvoError(f"checkpoint's model_config: {error.message}", path) from None


def _normalization_of(state: dict, outputs: int, path: str | Path | None = None) -> Normalization:
    """The checkpoint's normalisation, checked: ``outputs`` finite means and positive scales."""
    try:
        normalization = Normalization.from_dict(state["normalization"])
    except (KeyError, TypeError, ValueError):
        raise FlowvoError("checkpoint's normalization is incomplete or not numeric", path) from None
    if not len(normalization.target_mean) == len(normalization.target_std) == outputs:
        raise FlowvoError(f"checkpoint's normalization does not have {outputs} values per target", path)
    values = [*normalization.target_mean, *normalization.target_std, normalization.flow_std_px]
    if not all(math.isfinite(v) for v in values) or min(*normalization.target_std, normalization.flow_std_px) <= 0:
        raise FlowvoError("checkpoint's normalization holds NaN, infinite or non-positive scales", path)
    return normalization


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
    config = model_config_of(state, path)
    if expected is not None:
        check_compatible(state, expected, path)
    model = OdometryNet(config)
    try:
        model.load_state_dict(state["model_state"])
    except (RuntimeError, TypeError, AttributeError):
        raise FlowvoError("weights do not fit the architecture stored in the checkpoint", path) from None
    return model.eval(), _normalization_of(state, config.outputs, path), state


def write_slim_checkpoint(source: str | Path, target: str | Path) -> Path:
    """A deployable checkpoint: float16 weights, configuration, normalisation and training history;
    no optimiser, scheduler or RNG state (so it cannot be resumed, only run)."""
    state = read_checkpoint(source)
    keep = ("model_config", "train_config", "normalization", "flow_size_hw", "history", "epoch", "best")
    slim = {key: state[key] for key in keep if key in state}
    slim["model_state"] = {k: v.half() if v.is_floating_point() else v for k, v in state["model_state"].items()}
    save_checkpoint(target, slim)
    return Path(target)
