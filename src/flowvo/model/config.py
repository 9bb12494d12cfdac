"""Run configuration as dataclasses with defaults, loadable from YAML and saved next to every run."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path

import yaml

from flowvo.errors import FlowvoError
from flowvo.flow.cache_root import default_cache_root
from flowvo.io.atomic import write_text_atomic
from flowvo.kitti.sequence import sequence_name

SPLITS = {
    "kitti": (["00", "01", "02", "03", "04", "05", "06", "07"], ["08", "09", "10"]),
}


def check_number(name: str, value: object, kind: type, low: float, high: float = math.inf) -> int | float:
    """``value`` as ``kind`` (int or float) if it is a finite number in [low, high]; else a FlowvoError
    naming the option (YAML ``epochs: ten`` or ``lr: .nan`` are refused, not trained with)."""
    integral = isinstance(value, (int, float)) and float(value).is_integer()
    if isinstance(value, bool) or not isinstance(value, (int, float)) or (kind is int and not integral):
        raise FlowvoError(f"{name} must be {'an integer' if kind is int else 'a number'}, got {value!r}")
    if not (math.isfinite(value) and low <= value <= high):
        raise FlowvoError(f"{name} must be in [{low:g}, {high:g}], got {value!r}")
    return kind(value)


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
        self.validate()

    def validate(self) -> None:
        """Raise a FlowvoError naming the first option out of range (also after fields were changed)."""
        if not isinstance(self.input_hw, (list, tuple)) or len(self.input_hw) != 2:
            raise FlowvoError(f"model input_hw must be [height, width], got {self.input_hw!r}")
        self.input_hw = (check_number("model input_hw", self.input_hw[0], int, 8, 4096),
                         check_number("model input_hw", self.input_hw[1], int, 8, 4096))
        if self.head not in ("planar", "se3"):
            raise FlowvoError(f"model head must be 'planar' or 'se3', got {self.head!r}")
        check_number("model stack", self.stack, int, 1, 16)
        check_number("model width", self.width, float, 0.01, 4.0)
        check_number("model fc_units", self.fc_units, int, 1, 16384)
        check_number("model dropout", self.dropout, float, 0.0, 0.99)

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

    def __post_init__(self) -> None:
        self.validate()

    def validate(self) -> None:
        """Raise a FlowvoError naming the first option out of range (also after fields were changed)."""
        self.model.validate()
        for name in ("epochs", "batch_size", "early_stopping_patience"):
            setattr(self, name, check_number(name, getattr(self, name), int, 1))
        for name in ("seed", "workers"):
            setattr(self, name, check_number(name, getattr(self, name), int, 0))
        self.learning_rate = check_number("learning_rate", self.learning_rate, float, 1e-12, 10.0)
        self.weight_decay = check_number("weight_decay", self.weight_decay, float, 0.0, 10.0)
        self.flow_scale = check_number("flow_scale", self.flow_scale, float, 1e-3, 4.0)
        if self.schedule not in ("cosine", "constant"):
            raise FlowvoError(f"schedule must be 'cosine' or 'constant', got {self.schedule!r}")
        for name in ("train_sequences", "val_sequences"):
            names = getattr(self, name)
            if not isinstance(names, list) or not names or not all(isinstance(n, (str, int)) for n in names):
                raise FlowvoError(f"{name} must be a non-empty list of sequence names, got {names!r}")
            setattr(self, name, [sequence_name(str(n)) for n in names])
        if self.loss_weights is not None:
            if not isinstance(self.loss_weights, list) or len(self.loss_weights) != self.model.outputs:
                raise FlowvoError(f"loss_weights must list {self.model.outputs} numbers (one per output of the "
                                  f"{self.model.head} head), got {self.loss_weights!r}")
            self.loss_weights = [check_number("loss_weights", w, float, 0.0) for w in self.loss_weights]
        for name in ("data", "out", "device", "flow_method"):
            if not isinstance(getattr(self, name), str):
                raise FlowvoError(f"{name} must be text, got {getattr(self, name)!r}")

    @property
    def cache_root(self) -> str:
        """``flow_cache``, or the dataset's folder in the user's cache (:mod:`flowvo.flow.cache_root`)."""
        return self.flow_cache or str(default_cache_root(self.data))

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
        if not isinstance(model, dict):
            raise FlowvoError(f"model must be a mapping of option: value, got {model!r}", source)
        model_known = {f.name for f in fields(ModelConfig)}
        if set(model) - model_known:
            raise FlowvoError(f"unknown model option(s): {', '.join(sorted(set(model) - model_known))}", source)
        try:
            return cls(model=ModelConfig(**model), **values)
        except FlowvoError as error:  # name the file the bad value came from
            raise FlowvoError(error.message, source if error.path is None else error.path) from None

    @classmethod
    def from_yaml(cls, path: str | Path) -> TrainConfig:
        path = Path(path)
        if not path.is_file():
            raise FlowvoError("config file not found", path)
        try:
            data = yaml.safe_load(path.read_text(encoding="utf-8")) or {}
        except UnicodeDecodeError:
            raise FlowvoError("not valid YAML (not UTF-8 text)", path) from None
        except yaml.YAMLError as error:
            line = getattr(getattr(error, "problem_mark", None), "line", None)
            raise FlowvoError("not valid YAML", path, None if line is None else line + 1) from None
        if not isinstance(data, dict):
            raise FlowvoError("expected a mapping of option: value", path)
        return cls.from_dict(data, path)

    def save_yaml(self, path: str | Path) -> None:
        write_text_atomic(path, yaml.safe_dump(self.to_dict(), sort_keys=False))


# Settings that shape a training run: a resumed run must keep them, or the log and checkpoints would
# describe a run that never happened. ``epochs`` joins them under the cosine schedule, whose length the
# saved scheduler state already encodes; paths, device, workers and patience may change.
RESUME_FIXED = ("train_sequences", "val_sequences", "flow_method", "flow_scale", "mirror", "batch_size",
                "learning_rate", "weight_decay", "schedule", "loss_weights", "seed")


def check_resume_config(stored: dict, config: TrainConfig, path: str | Path) -> None:
    """Refuse to resume the run recorded as ``stored`` (a checkpoint's train_config) with ``config``
    when a setting that shapes the result differs; the message names each difference."""
    current = config.to_dict()
    keys = RESUME_FIXED + (("epochs",) if config.schedule == "cosine" else ())
    differences = [f"{key}={current[key]!r} (the run has {stored.get(key)!r})" for key in keys
                   if stored.get(key) != current[key]]
    if differences:
        raise FlowvoError("cannot resume with other settings: " + ", ".join(differences) + "; resume with the "
                          "run's settings, or start a new run (another --out, or --force)", path)
