"""Training: AdamW, cosine schedule, per-epoch checkpoints, resume, CSV log, early stopping, DDP.

One code path for one process and for ``torchrun --nproc_per_node=N`` (DistributedDataParallel, gloo on
CPU, nccl on GPU): a DistributedSampler with one replica is the single-process case.
"""

from __future__ import annotations

import csv
import math
import os
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np
import torch
import torch.distributed as dist
from torch.nn.parallel import DistributedDataParallel
from torch.utils.data import DataLoader, DistributedSampler

from flowvo.errors import FlowvoError
from flowvo.flow.cache import FlowCache
from flowvo.flow.registry import create_estimator
from flowvo.io.atomic import atomic_open
from flowvo.io.outputs import prepare_output_dir, remove_outputs
from flowvo.kitti.sequence import KittiSequence
from flowvo.metrics import kitti_odometry as kitti
from flowvo.model.checkpoint import check_compatible, read_resumable_checkpoint, save_checkpoint
from flowvo.model.config import TrainConfig, check_resume_config
from flowvo.model.data import OdometryDataset, fit_normalization, load_network_flows, motion_targets
from flowvo.model.device import check_device
from flowvo.model.inference import chain_motions, predict_targets
from flowvo.model.network import OdometryNet
from flowvo.model.preprocess import Normalization
from flowvo.progress import progress
from flowvo.trajectory import Trajectory

TRAIN_OUTPUTS = ["last.pt", "best.pt", "log.csv", "config.yaml", "learning_curve.png"]
MIN_TRAVEL_M = 1.0  # in all training sequences together
LOG_FIELDS = ["epoch", "train_loss", "val_loss", "val_t_err_percent", "val_r_err_deg_per_m", "lr", "seconds"]


def load_split(config: TrainConfig, names: list[str], flows_needed: bool = True
               ) -> tuple[list[torch.Tensor], list[np.ndarray], list, list]:
    """Flows at the network input size, targets, GT poses and the flow size (H, W) of the named
    sequences (computing any missing flow cache first)."""
    flows, targets, poses, sizes = [], [], [], []
    estimator = create_estimator(config.flow_method)
    for name in names:
        sequence = KittiSequence(config.data, name)
        if not sequence.has_poses:
            raise FlowvoError("training and validation need ground-truth poses", sequence.pose_path)
        cache = FlowCache(config.cache_root, sequence, config.flow_method, config.flow_scale, estimator.params())
        cache.compute(estimator)  # fills missing chunks, recomputes damaged ones (checksums), else no-op
        if flows_needed:
            flows.append(load_network_flows(cache, config.model.input_hw, name))
        targets.append(motion_targets(sequence.poses.T_world_cam, config.model.head))
        poses.append(sequence.poses)
        sizes.append(list(cache.flow_size_hw))
    return flows, targets, poses, sizes


def _distributed() -> tuple[int, int]:
    world = int(os.environ.get("WORLD_SIZE", "1"))
    if world > 1 and not dist.is_initialized():
        on_gpu = torch.cuda.is_available() and os.environ.get("FLOWVO_DEVICE", "cpu").startswith("cuda")
        dist.init_process_group(backend="nccl" if on_gpu else "gloo")
    return (dist.get_rank(), dist.get_world_size()) if dist.is_initialized() else (0, 1)


def _validation_metrics(model, normalization, flows, poses, config) -> dict:
    """Val loss on normalised targets and the pooled KITTI metric of the chained val trajectories."""
    losses, segments = [], []
    for flow, truth in zip(flows, poses, strict=True):
        predicted = predict_targets(model, normalization, flow, config.model.stack, config.device)
        target = motion_targets(truth.T_world_cam, config.model.head)
        diff = normalization.normalize(predicted) - normalization.normalize(target)
        losses.append((diff**2).mean(1))
        chained = Trajectory.from_poses(chain_motions(predicted, config.model.head))
        segments.append(kitti.sequence_segment_errors(truth, chained))
    pooled = kitti.SegmentErrors.concatenate(segments)
    result = {"val_loss": float(np.concatenate(losses).mean())}
    if len(pooled):
        summary = kitti.summarize(pooled)
        result.update(val_t_err_percent=summary["t_err_percent"], val_r_err_deg_per_m=summary["r_err_deg_per_m"])
    else:  # validation paths shorter than 100 m: no KITTI segment
        result.update(val_t_err_percent=math.nan, val_r_err_deg_per_m=math.nan)
    return result


def _selection_score(row: dict) -> float:
    """What best.pt minimises: validation t_err (%), or the validation loss where no segment exists."""
    return row["val_t_err_percent"] if not math.isnan(row["val_t_err_percent"]) else row["val_loss"]


def _check_targets_move(targets: list[np.ndarray], names: list[str], config: TrainConfig) -> None:
    """Refuse training data whose camera never moves: every target would be its mean, the normalisation
    would divide by ~0 and the 'trained' model would be meaningless."""
    stacked = np.concatenate(targets)
    travelled_m = float(np.abs(stacked[:, 0] if config.model.head == "planar" else stacked[:, :3]).sum())
    if travelled_m < MIN_TRAVEL_M:
        raise FlowvoError(f"the camera of the training sequence(s) {' '.join(names)} moves {travelled_m:.3g} m in all: "
                          "nothing to learn from; train on sequences that drive", config.data)


def train(config: TrainConfig, resume: bool = False, stop_after_epochs: int | None = None,
          force: bool = False) -> Path:
    """Train and return the folder holding ``best.pt``, ``last.pt``, ``log.csv`` and ``config.yaml``.

    A folder holding an earlier run is refused unless ``resume`` (continue it: every setting that shapes
    the result must be unchanged) or ``force`` (start over: its outputs are removed first).
    ``stop_after_epochs`` ends the run early (as if killed) after that many epochs of this call.
    """
    config.validate()
    check_device(config.device)
    if resume and force:
        raise FlowvoError("--resume continues the run in --out, --force replaces it: give one of them")
    rank, world = _distributed()
    out = Path(config.out)
    torch.manual_seed(config.seed)
    np.random.seed(config.seed)
    state = None
    prepare_output_dir(out, [] if resume or rank else TRAIN_OUTPUTS, force, dataset=config.data)
    if force and not rank:  # a fresh run must not resume from (or keep) the replaced run's checkpoints
        remove_outputs(out, TRAIN_OUTPUTS)
    if resume:
        if not (out / "last.pt").is_file():
            raise FlowvoError("nothing to resume: no last.pt", out)
        state = read_resumable_checkpoint(out / "last.pt")
        check_compatible(state, config.model, out / "last.pt")
        check_resume_config(state["train_config"], config, out / "last.pt")
    if world > 1:  # one process fills missing flow caches, the others wait and then read them
        torch.set_num_threads(max(1, (os.cpu_count() or 1) // world))
        if rank == 0:
            load_split(config, config.train_sequences + config.val_sequences, flows_needed=False)
        dist.barrier()
    train_flows, train_targets, _, flow_sizes = load_split(config, config.train_sequences)
    _check_targets_move(train_targets, config.train_sequences, config)
    val_flows, _, val_poses, _ = load_split(config, config.val_sequences)
    normalization = (Normalization.from_dict(state["normalization"]) if state else
                     fit_normalization(train_targets, train_flows, config.model.head, config.mirror))
    dataset = OdometryDataset(train_flows, train_targets, normalization, config.model.head, config.model.stack,
                              config.mirror)
    sampler = DistributedSampler(dataset, num_replicas=world, rank=rank, shuffle=True, seed=config.seed)
    loader = DataLoader(dataset, batch_size=config.batch_size, sampler=sampler, num_workers=config.workers,
                        drop_last=len(dataset) > config.batch_size * world)
    model = OdometryNet(config.model).to(config.device)
    optimizer = torch.optim.AdamW(model.parameters(), lr=config.learning_rate, weight_decay=config.weight_decay)
    if config.schedule == "cosine":
        scheduler = torch.optim.lr_scheduler.CosineAnnealingLR(optimizer, T_max=config.epochs * len(loader))
    else:
        scheduler = torch.optim.lr_scheduler.LambdaLR(optimizer, lambda _: 1.0)
    weights = torch.tensor(config.loss_weights or [1.0] * config.model.outputs, device=config.device)
    start_epoch, best, bad_epochs, history = 0, math.inf, 0, []
    if state:
        model.load_state_dict(state["model_state"])
        optimizer.load_state_dict(state["optimizer_state"])
        scheduler.load_state_dict(state["scheduler_state"])
        start_epoch, best, bad_epochs = state["epoch"] + 1, state["best"], state["bad_epochs"]
        history = state["history"]
        torch.set_rng_state(state["rng_state"])
    network = DistributedDataParallel(model) if world > 1 else model
    if rank == 0:
        out.mkdir(parents=True, exist_ok=True)
        config.save_yaml(out / "config.yaml")
    epochs_run = 0
    for epoch in range(start_epoch, config.epochs):
        if bad_epochs >= config.early_stopping_patience or (stop_after_epochs is not None
                                                             and epochs_run >= stop_after_epochs):
            break
        started = time.perf_counter()
        sampler.set_epoch(epoch)
        network.train()
        total, count = 0.0, 0
        for inputs, targets in progress(loader, f"epoch {epoch + 1}/{config.epochs}", len(loader), "batch"):
            inputs, targets = inputs.to(config.device), targets.to(config.device)
            loss = (weights * (network(inputs) - targets) ** 2).mean()
            optimizer.zero_grad(set_to_none=True)
            loss.backward()
            optimizer.step()
            scheduler.step()
            total += loss.item() * len(inputs)
            count += len(inputs)
            if not math.isfinite(total):
                raise FlowvoError(f"training diverged: loss {loss.item()} in epoch {epoch + 1}; lower --lr "
                                  "(the last completed epoch is kept in last.pt)", out)
        model.eval()
        row = {"epoch": epoch + 1, "train_loss": total / max(count, 1),
               **_validation_metrics(model, normalization, val_flows, val_poses, config),
               "lr": optimizer.param_groups[0]["lr"], "seconds": time.perf_counter() - started}
        score = _selection_score(row)
        improved = score < best
        best, bad_epochs = (score, 0) if improved else (best, bad_epochs + 1)
        history.append(row)
        epochs_run += 1
        if rank == 0:
            checkpoint = {
                "model_config": asdict(config.model), "train_config": config.to_dict(),
                "normalization": normalization.to_dict(), "model_state": model.state_dict(),
                "optimizer_state": optimizer.state_dict(), "scheduler_state": scheduler.state_dict(),
                "epoch": epoch, "best": best, "bad_epochs": bad_epochs, "history": history,
                "rng_state": torch.get_rng_state(), "flow_size_hw": flow_sizes[0],
            }
            save_checkpoint(out / "last.pt", checkpoint)
            if improved:
                save_checkpoint(out / "best.pt", checkpoint)
            _write_log(out / "log.csv", history)
    if rank == 0 and history:
        from flowvo.model.learning_curve import plot_learning_curve

        best_epoch = min(history, key=_selection_score)["epoch"]  # the first best, as best.pt keeps
        plot_learning_curve(history, out / "learning_curve.png", best_epoch, config.val_sequences)
    if world > 1:
        dist.barrier()
        dist.destroy_process_group()
    return out


def _write_log(path: Path, history: list[dict]) -> None:
    with atomic_open(path) as handle:
        writer = csv.DictWriter(handle, fieldnames=LOG_FIELDS)
        writer.writeheader()
        for row in history:
            writer.writerow({k: row[k] for k in LOG_FIELDS})
