"""Run configuration as dataclasses with defaults, loadable from YAML and saved next to every run."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, fields
from pathlib import Path

import yaml

from flowvo.atomic import write_text_atomic
from flowvo.errors import FlowvoError

SPLITS = {
    "kitti": (["00", "01", "02", "03", "04", "05", "06", "07"], ["08", "09", "10"]),
}


@dataclass
class ModelConfig:
    """Network shape. ``width`` multiplies every channel count (1.0 = the thesis network)."""

    width: float = 0.25
    input_hw: tuple[int, int] = (96, 320)
    head: str = "planar"  # planar: (distance m, heading change rad); se3: (tx, ty, tz, rx, ry, rz)
    stack: int = 1  # consecutive flow fields as input channels (2 * stack)
    fc_units: int = 1024
    dropout: float = 0.5

    def __post_init__(self) -> None:
        self.input_hw = tuple(int(v) for v in self.input_hw)
        if self.head not in ("planar", "se3"):
            raise FlowvoError(f"model head must be 'planar' or 'se3', got {self.head!r}")
        if self.stack < 1 or self.width <= 0:
            raise FlowvoError("model stack must be >= 1 and width > 0")

    @property
    def outputs(self) -> int:
        return 2 if self.head == "planar" else 6


@dataclass
class TrainConfig:
    """Everything a training run depends on; ``flow_scale`` is relative to the frames on disk."""

    data: str = ""
    train_sequences: list[str] = field(default_factory=lambda: list(SPLITS["kitti"][0]))
    val_sequences: list[str] = field(default_factory=lambda: list(SPLITS["kitti"][1]))
    flow_method: str = "dis-medium"
    flow_scale: float = 0.5
    flow_cache: str | None = None
    model: ModelConfig = field(default_factory=ModelConfig)
    mirror: bool = True
    epochs: int = 30
    batch_size: int = 64
    learning_rate: float = 1e-3
    weight_decay: float = 1e-4
    schedule: str = "cosine"  # cosine | constant
    loss_weights: list[float] | None = None  # per output; default 1 each on normalised targets
    early_stopping_patience: int = 6
    seed: int = 0
    out: str = "runs/train"
    device: str = "cpu"
    workers: int = 0

    @property
    def cache_root(self) -> str:
        return self.flow_cache or f"{self.data}/flow_cache"

    def to_dict(self) -> dict:
        data = asdict(self)
        data["model"]["input_hw"] = list(self.model.input_hw)
        return data

    @classmethod
    def from_dict(cls, data: dict, source: str | Path = "<config>") -> TrainConfig:
        known = {f.name for f in fields(cls)}
        unknown = set(data) - known
        if unknown:
            raise FlowvoError(f"unknown training option(s): {', '.join(sorted(unknown))}", source)
        values = dict(data)
        if "split" in values:
            values.pop("split")
        model = values.pop("model", {}) or {}
        model_known = {f.name for f in fields(ModelConfig)}
        if set(model) - model_known:
            raise FlowvoError(f"unknown model option(s): {', '.join(sorted(set(model) - model_known))}", source)
        return cls(model=ModelConfig(**model), **values)

    @classmethod
    def from_yaml(cls, path: str | Path) -> TrainConfig:
        path = Path(path)
        if not path.is_file():
            raise FlowvoError("config file not found", path)
        try:
            data = yaml.safe_load(path.read_text()) or {}
        except yaml.YAMLError as error:
            line = getattr(getattr(error, "problem_mark", None), "line", None)
            raise FlowvoError("not valid YAML", path, None if line is None else line + 1) from None
        if not isinstance(data, dict):
            raise FlowvoError("expected a mapping of option: value", path)
        return cls.from_dict(data, path)

    def save_yaml(self, path: str | Path) -> None:
        write_text_atomic(path, yaml.safe_dump(self.to_dict(), sort_keys=False))
