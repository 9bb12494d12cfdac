"""The learning-curve figure: train/val loss and validation KITTI t_err per epoch."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from flowvo.io.atomic import atomic_path  # noqa: E402


def plot_learning_curve(history: list[dict], path: str | Path, best_epoch: int,
                        val_sequences: list[str] | None = None) -> Path:
    """Two panels: losses (log scale) and validation t_err (%) against epoch, ``best_epoch`` (best.pt) marked."""
    epochs = [row["epoch"] for row in history]
    figure, (left, right) = plt.subplots(1, 2, figsize=(10, 3.8))
    left.plot(epochs, [row["train_loss"] for row in history], "o-", label="train loss")
    left.plot(epochs, [row["val_loss"] for row in history], "s-", label="validation loss")
    left.set_yscale("log")
    left.set_xlabel("epoch")
    left.set_ylabel("MSE of normalised targets")
    left.legend()
    left.grid(alpha=0.3)
    right.plot(epochs, [row["val_t_err_percent"] for row in history], "o-", color="C2")
    best = next(row for row in history if row["epoch"] == best_epoch)
    right.plot([best_epoch], [best["val_t_err_percent"]], "*", color="C3", markersize=16,
               label=f"best.pt (epoch {best_epoch})")
    right.legend()
    right.set_xlabel("epoch")
    on = f" on {' '.join(val_sequences)}" if val_sequences else ""
    right.set_ylabel(f"validation KITTI t_err{on} [%]")
    right.grid(alpha=0.3)
    with atomic_path(path) as tmp:
        figure.savefig(tmp, dpi=110, bbox_inches="tight", format="png")
    plt.close(figure)
    return Path(path)
