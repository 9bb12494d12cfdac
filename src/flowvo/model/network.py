"""The odometry CNN: the contracting half of FlowNetS on a 2K-channel flow input, FC 1024, dropout, head.

Layers (channels x ``width``): conv1 7x7/2 64, conv2 5x5/2 128, conv3 5x5/2 256, conv3_1 3x3 256,
conv4 3x3/2 512, conv4_1 512, conv5 3x3/2 512, conv5_1 512, conv6 3x3/2 1024, conv6_1 1024; leaky ReLU
(slope 0.1) after every convolution and after the fully connected layer; dropout 0.5; linear head.
"""

from __future__ import annotations

import torch
from torch import nn

from flowvo.model.config import ModelConfig

CONV_LAYERS = (  # name, output channels at width 1, kernel, stride
    ("conv1", 64, 7, 2), ("conv2", 128, 5, 2), ("conv3", 256, 5, 2), ("conv3_1", 256, 3, 1),
    ("conv4", 512, 3, 2), ("conv4_1", 512, 3, 1), ("conv5", 512, 3, 2), ("conv5_1", 512, 3, 1),
    ("conv6", 1024, 3, 2), ("conv6_1", 1024, 3, 1),
)


def feature_size(input_hw: tuple[int, int]) -> tuple[int, int]:
    """Spatial size after the six stride-2 convolutions (padding (k-1)/2)."""
    h, w = input_hw
    for _, _, kernel, stride in CONV_LAYERS:
        pad = (kernel - 1) // 2
        h = (h + 2 * pad - kernel) // stride + 1
        w = (w + 2 * pad - kernel) // stride + 1
    return h, w


class OdometryNet(nn.Module):
    """Flow (B, 2K, H, W) in network-input pixels -> normalised motion (B, 2 or 6)."""

    def __init__(self, config: ModelConfig) -> None:
        super().__init__()
        self.config = config
        layers: list[nn.Module] = []
        channels = 2 * config.stack
        for _, base, kernel, stride in CONV_LAYERS:
            out = max(8, int(round(base * config.width)))
            layers += [nn.Conv2d(channels, out, kernel, stride, (kernel - 1) // 2), nn.LeakyReLU(0.1)]
            channels = out
        self.encoder = nn.Sequential(*layers)
        fh, fw = feature_size(config.input_hw)
        self.fc = nn.Sequential(
            nn.Flatten(), nn.Linear(channels * fh * fw, config.fc_units), nn.LeakyReLU(0.1), nn.Dropout(config.dropout)
        )
        self.head = nn.Linear(config.fc_units, config.outputs)

    def forward(self, flow: torch.Tensor) -> torch.Tensor:
        return self.head(self.fc(self.encoder(flow)))


def parameter_count(model: nn.Module) -> int:
    """Number of trainable parameters."""
    return sum(p.numel() for p in model.parameters() if p.requires_grad)


def flops_per_frame(model: OdometryNet) -> int:
    """Multiply-adds x 2 of one forward pass (convolutions and linear layers)."""
    total = 0

    def count(module: nn.Module, _inputs, output: torch.Tensor) -> None:
        nonlocal total
        if isinstance(module, nn.Conv2d):
            k = module.kernel_size[0] * module.kernel_size[1] * module.in_channels // module.groups
            total += 2 * k * output.numel()
        elif isinstance(module, nn.Linear):
            total += 2 * module.in_features * module.out_features

    hooks = [m.register_forward_hook(count) for m in model.modules() if isinstance(m, (nn.Conv2d, nn.Linear))]
    was_training = model.training
    model.eval()
    with torch.no_grad():
        model(torch.zeros(1, 2 * model.config.stack, *model.config.input_hw))
    model.train(was_training)
    for hook in hooks:
        hook.remove()
    return total
