"""Train the odometry network: ``flowvo train``."""

from __future__ import annotations

import argparse
from pathlib import Path

from flowvo.cli.arguments import FLOW_SCALE, NON_NEGATIVE_INT, POSITIVE_INT, bounded, force_flag
from flowvo.errors import FlowvoError


def command(args: argparse.Namespace) -> int:
    from flowvo.model.config import SPLITS, TrainConfig
    from flowvo.model.train import train

    run_config = Path(args.out or TrainConfig().out, "config.yaml")
    if args.config:
        config = TrainConfig.from_yaml(args.config)
    else:  # --resume alone continues with the run's own settings
        config = TrainConfig.from_yaml(run_config) if args.resume and run_config.is_file() else TrainConfig()
    overrides = {"data": args.data, "out": args.out, "epochs": args.epochs, "batch_size": args.batch_size,
                 "learning_rate": args.lr, "seed": args.seed, "flow_method": args.flow_method,
                 "flow_scale": args.flow_scale, "flow_cache": args.cache, "device": args.device}
    for key, value in overrides.items():
        if value is not None:
            setattr(config, key, value)
    if args.split:
        config.train_sequences, config.val_sequences = (list(s) for s in SPLITS[args.split])
    if args.train:
        config.train_sequences = args.train
    if args.val:
        config.val_sequences = args.val
    if args.width:
        config.model.width = args.width
    if args.head:
        config.model.head = args.head
    if args.stack:
        config.model.stack = args.stack
    if not config.data:
        raise FlowvoError("no data: give --data ROOT or 'data:' in the config")
    config.validate()
    from flowvo.model.network import OdometryNet, flops_per_frame, parameter_count

    network = OdometryNet(config.model)
    print(f"model: width {config.model.width}, input {config.model.input_hw[1]}x{config.model.input_hw[0]}, "
          f"head {config.model.head}, stack {config.model.stack}: {parameter_count(network) / 1e6:.2f} M parameters, "
          f"{flops_per_frame(network) / 1e9:.3f} GFLOP per frame")
    out = train(config, resume=args.resume, force=args.force)
    print(f"training finished: {out}/best.pt, log {out}/log.csv, curve {out}/learning_curve.png")
    return 0


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("train", help="train the odometry CNN (checkpoints every epoch, --resume, DDP via torchrun)")
    p.add_argument("--config", help="YAML with TrainConfig fields (flags below override it)")
    p.add_argument("--data", help="dataset root (KITTI layout, real or synthetic)")
    p.add_argument("--out", help="run folder (default runs/train)")
    p.add_argument("--split", choices=("kitti",),
                   help="preset split: kitti = train 00-07, validate 08-10 (the reference split has no "
                        "separate validation set: epoch selection then sees the test sequences)")
    p.add_argument("--train", nargs="+", help="training sequences")
    p.add_argument("--val", nargs="+", help="validation sequences")
    p.add_argument("--epochs", type=POSITIVE_INT)
    p.add_argument("--batch-size", type=POSITIVE_INT)
    p.add_argument("--lr", type=bounded(float, 0.0, 10.0, low_open=True))
    p.add_argument("--seed", type=NON_NEGATIVE_INT)
    p.add_argument("--width", type=bounded(float, 0.01, 4.0), help="channel width multiplier (1.0 = thesis network)")
    p.add_argument("--head", choices=("planar", "se3"))
    p.add_argument("--stack", type=bounded(int, 1, 16), help="consecutive flow fields as input")
    p.add_argument("--flow-method", help="flow method of the caches")
    p.add_argument("--flow-scale", type=FLOW_SCALE, help="flow working scale relative to the frames")
    p.add_argument("--cache", help="flow cache root (default: the user's cache folder, see 'flowvo flow --help')")
    p.add_argument("--device", help="cpu or cuda")
    p.add_argument("--resume", action="store_true",
                   help="continue from OUT/last.pt with the run's settings (changing one that shapes the result "
                        "is refused)")
    force_flag(p, "an earlier training run in --out (its checkpoints and log are removed first)")
    p.set_defaults(func=command)
