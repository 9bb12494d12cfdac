"""FlowNetS (Dosovitskiy et al. 2015), the full encoder-decoder, in the layout of the widely used public
PyTorch port (state_dict keys ``conv1.0.weight`` ... ``predict_flow2.weight``), for user-supplied weights.

Input: two RGB frames scaled to 0..1 minus the port's channel means (0.411, 0.432, 0.45), stacked to 6
channels, sides padded up to multiples of 64. Output: flow at 1/4 resolution in units of input pixels
divided by 20, so the port multiplies by ``DIV_FLOW = 20`` after bilinear upsampling to input size.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from flowvo.errors import FlowvoError
from flowvo.io.torch_files import load_torch_file

DIV_FLOW = 20.0
MEAN_RGB = (0.411, 0.432, 0.45)
WEIGHTS_HELP = (
    "FlowNetS needs local weights: pass --flow-weights PATH to a checkpoint of the public PyTorch port "
    "(e.g. flownets_EPE1.951.pth from the FlowNetPytorch project's release page); flowvo never downloads"
)


def _conv(batch_norm: bool, c_in: int, c_out: int, kernel: int = 3, stride: int = 1) -> nn.Sequential:
    padding = (kernel - 1) // 2
    if batch_norm:
        return nn.Sequential(
            nn.Conv2d(c_in, c_out, kernel, stride, padding, bias=False), nn.BatchNorm2d(c_out), nn.LeakyReLU(0.1)
        )
    return nn.Sequential(nn.Conv2d(c_in, c_out, kernel, stride, padding, bias=True), nn.LeakyReLU(0.1))


def _deconv(c_in: int, c_out: int) -> nn.Sequential:
    return nn.Sequential(nn.ConvTranspose2d(c_in, c_out, 4, 2, 1, bias=False), nn.LeakyReLU(0.1))


def _predict(c_in: int) -> nn.Conv2d:
    return nn.Conv2d(c_in, 2, 3, 1, 1, bias=False)


def _crop_like(x: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    return x[:, :, : target.shape[2], : target.shape[3]]


class FlowNetS(nn.Module):
    """FlowNetS: 6-channel frame pair in, flow/20 at 1/4 resolution out (highest-resolution head)."""

    def __init__(self, batch_norm: bool = False) -> None:
        super().__init__()
        self.conv1 = _conv(batch_norm, 6, 64, 7, 2)
        self.conv2 = _conv(batch_norm, 64, 128, 5, 2)
        self.conv3 = _conv(batch_norm, 128, 256, 5, 2)
        self.conv3_1 = _conv(batch_norm, 256, 256)
        self.conv4 = _conv(batch_norm, 256, 512, stride=2)
        self.conv4_1 = _conv(batch_norm, 512, 512)
        self.conv5 = _conv(batch_norm, 512, 512, stride=2)
        self.conv5_1 = _conv(batch_norm, 512, 512)
        self.conv6 = _conv(batch_norm, 512, 1024, stride=2)
        self.conv6_1 = _conv(batch_norm, 1024, 1024)
        self.deconv5 = _deconv(1024, 512)
        self.deconv4 = _deconv(1026, 256)
        self.deconv3 = _deconv(770, 128)
        self.deconv2 = _deconv(386, 64)
        self.predict_flow6 = _predict(1024)
        self.predict_flow5 = _predict(1026)
        self.predict_flow4 = _predict(770)
        self.predict_flow3 = _predict(386)
        self.predict_flow2 = _predict(194)
        for level in ("6_to_5", "5_to_4", "4_to_3", "3_to_2"):
            setattr(self, f"upsampled_flow{level}", nn.ConvTranspose2d(2, 2, 4, 2, 1, bias=False))

    def forward(self, pair: torch.Tensor) -> torch.Tensor:
        out2 = self.conv2(self.conv1(pair))
        out3 = self.conv3_1(self.conv3(out2))
        out4 = self.conv4_1(self.conv4(out3))
        out5 = self.conv5_1(self.conv5(out4))
        out6 = self.conv6_1(self.conv6(out5))
        flow = self.predict_flow6(out6)
        features = out6
        stages = ((out5, self.deconv5, self.upsampled_flow6_to_5, self.predict_flow5),
                  (out4, self.deconv4, self.upsampled_flow5_to_4, self.predict_flow4),
                  (out3, self.deconv3, self.upsampled_flow4_to_3, self.predict_flow3),
                  (out2, self.deconv2, self.upsampled_flow3_to_2, self.predict_flow2))
        for skip, deconv, upsample, predict in stages:
            features = torch.cat((skip, _crop_like(deconv(features), skip), _crop_like(upsample(flow), skip)), 1)
            flow = predict(features)
        return flow


def load_flownets(path: str | Path | None) -> FlowNetS:
    """FlowNetS with weights from a local checkpoint (a state_dict, or a dict holding 'state_dict')."""
    if path is None:
        raise FlowvoError(WEIGHTS_HELP)
    path = Path(path)
    if not path.is_file():
        raise FlowvoError(f"weights file not found. {WEIGHTS_HELP}", path)
    checkpoint = load_torch_file(path)
    state = checkpoint.get("state_dict", checkpoint) if isinstance(checkpoint, dict) else None
    if not isinstance(state, dict) or "conv1.0.weight" not in state:
        raise FlowvoError("not a FlowNetS state_dict (no key conv1.0.weight)", path)
    model = FlowNetS(batch_norm="conv1.1.weight" in state)
    try:
        model.load_state_dict(state, strict=True)
    except RuntimeError as error:
        first = str(error).splitlines()[1].strip() if "\n" in str(error) else str(error)
        raise FlowvoError(f"does not match the FlowNetS layout: {first}", path) from None
    return model.eval()


class FlowNetSFlow:
    """Flow from a FlowNetS checkpoint; grey frames are replicated to RGB."""

    def __init__(self, name: str, weights: str | Path | None, device: str = "cpu") -> None:
        self.name, self.weights, self.device = name, str(weights), device
        self.model = load_flownets(weights).to(device)

    @torch.no_grad()
    def estimate(self, prev: np.ndarray, next: np.ndarray) -> np.ndarray:
        h, w = prev.shape[:2]
        frames = []
        for image in (prev, next):
            rgb = np.repeat(image[..., None], 3, axis=2) if image.ndim == 2 else image[..., ::-1]
            tensor = torch.from_numpy(np.ascontiguousarray(rgb)).float().permute(2, 0, 1) / 255.0
            frames.append(tensor - torch.tensor(MEAN_RGB)[:, None, None])
        pair = torch.cat(frames, 0)[None].to(self.device)
        ph, pw = -(-h // 64) * 64, -(-w // 64) * 64
        pair = F.pad(pair, (0, pw - w, 0, ph - h), mode="replicate")
        flow = self.model(pair)
        flow = DIV_FLOW * F.interpolate(flow, size=(ph, pw), mode="bilinear", align_corners=False)
        return flow[0, :, :h, :w].permute(1, 2, 0).cpu().numpy().astype(np.float32)

    def params(self) -> dict:
        return {"weights": self.weights, "div_flow": DIV_FLOW}

