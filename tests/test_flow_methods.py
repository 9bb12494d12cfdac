import cv2
import numpy as np
import pytest
import torch

from flowvo.errors import FlowvoError
from flowvo.flow.registry import available_methods, create_estimator
from flowvo.flow.visualize import color_legend, flow_to_color
from flowvo.synth.textures import band_limited_noise

CLASSICAL_EPE_LIMITS_PX = {  # measured: shift / zoom mean EPE on the interior
    "dis-ultrafast": (0.2, 0.4),  # 0.09 / 0.24
    "dis-fast": (0.15, 0.3),  # 0.06 / 0.15
    "dis-medium": (0.1, 0.15),  # 0.02 / 0.06
    "farneback": (0.05, 0.15),  # 0.001 / 0.06
}


def textured_image() -> np.ndarray:
    noise = band_limited_noise(np.random.default_rng(0), 512, 1.2)
    return np.clip(128 + 40 * noise, 0, 255).astype(np.uint8)[:200, :480]


def warped_pair(affine: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    image = textured_image()
    h, w = image.shape
    following = cv2.warpAffine(image, affine, (w, h), flags=cv2.INTER_CUBIC, borderMode=cv2.BORDER_REFLECT)
    v, u = np.mgrid[0:h, 0:w].astype(np.float64)
    true_flow = np.stack([affine[0, 0] * u + affine[0, 1] * v + affine[0, 2] - u,
                          affine[1, 0] * u + affine[1, 1] * v + affine[1, 2] - v], -1)
    return image, following, true_flow


SHIFT = np.array([[1.0, 0.0, 3.0], [0.0, 1.0, -2.0]])
ZOOM = np.array([[1.04, 0.0, -0.02 * 480], [0.0, 1.04, -0.02 * 200]])  # 4 % about the centre


@pytest.mark.parametrize("method", sorted(CLASSICAL_EPE_LIMITS_PX))
def test_classical_methods_recover_translation_and_zoom(method):
    estimator = create_estimator(method)
    for affine, limit in zip((SHIFT, ZOOM), CLASSICAL_EPE_LIMITS_PX[method], strict=True):
        image, following, true_flow = warped_pair(affine)
        flow = estimator.estimate(image, following)
        assert flow.dtype == np.float32 and flow.shape == (200, 480, 2)
        epe = np.linalg.norm(flow - true_flow, axis=-1)[20:-20, 20:-20].mean()
        assert epe < limit


def test_registry_lists_every_method_and_rejects_unknown():
    assert {"dis-ultrafast", "dis-fast", "dis-medium", "farneback", "flownets", "raft-small"} <= set(
        available_methods()
    )
    with pytest.raises(FlowvoError, match="unknown flow method 'brox'"):
        create_estimator("brox")


def flownets_reference_layout(batch_norm: bool) -> dict[str, tuple[int, ...]]:
    """Key -> shape of the public PyTorch port's FlowNetS state_dict, written out independently."""
    layers = [("conv1", 6, 64, 7), ("conv2", 64, 128, 5), ("conv3", 128, 256, 5), ("conv3_1", 256, 256, 3),
              ("conv4", 256, 512, 3), ("conv4_1", 512, 512, 3), ("conv5", 512, 512, 3), ("conv5_1", 512, 512, 3),
              ("conv6", 512, 1024, 3), ("conv6_1", 1024, 1024, 3)]
    layout: dict[str, tuple[int, ...]] = {}
    for name, c_in, c_out, k in layers:
        layout[f"{name}.0.weight"] = (c_out, c_in, k, k)
        if batch_norm:
            for field in ("weight", "bias", "running_mean", "running_var"):
                layout[f"{name}.1.{field}"] = (c_out,)
            layout[f"{name}.1.num_batches_tracked"] = ()
        else:
            layout[f"{name}.0.bias"] = (c_out,)
    for name, c_in, c_out in [("deconv5", 1024, 512), ("deconv4", 1026, 256), ("deconv3", 770, 128),
                              ("deconv2", 386, 64)]:
        layout[f"{name}.0.weight"] = (c_in, c_out, 4, 4)
    for level, c_in in [(6, 1024), (5, 1026), (4, 770), (3, 386), (2, 194)]:
        layout[f"predict_flow{level}.weight"] = (2, c_in, 3, 3)
    for a, b in [(6, 5), (5, 4), (4, 3), (3, 2)]:
        layout[f"upsampled_flow{a}_to_{b}.weight"] = (2, 2, 4, 4)
    return layout


@pytest.mark.parametrize("batch_norm", [False, True])
def test_flownets_loads_a_state_dict_of_the_public_layout(tmp_path, batch_norm):
    generator = torch.Generator().manual_seed(0)
    state = {}
    for key, shape in flownets_reference_layout(batch_norm).items():
        if key.endswith("num_batches_tracked"):
            state[key] = torch.tensor(0)
        elif key.endswith("running_var"):
            state[key] = torch.ones(shape)
        else:
            state[key] = torch.randn(shape, generator=generator) * 0.01
    torch.save({"arch": "flownets", "state_dict": state}, tmp_path / "flownets.pth")
    estimator = create_estimator("flownets", weights=str(tmp_path / "flownets.pth"))
    model_state = estimator.model.state_dict()
    assert set(model_state) == set(state)
    assert torch.equal(model_state["predict_flow2.weight"], state["predict_flow2.weight"])
    image = textured_image()[:100, :150]
    flow = estimator.estimate(image, image)
    assert flow.shape == (100, 150, 2) and flow.dtype == np.float32 and np.isfinite(flow).all()


def test_flownets_without_weights_says_where_to_get_them(tmp_path):
    with pytest.raises(FlowvoError, match="--flow-weights"):
        create_estimator("flownets")
    torch.save({"conv1.0.weight": torch.zeros(1)}, tmp_path / "bad.pth")
    with pytest.raises(FlowvoError, match="bad.pth: does not match the FlowNetS layout"):
        create_estimator("flownets", weights=str(tmp_path / "bad.pth"))


def test_raft_without_torchvision_or_weights_is_a_clear_error():
    with pytest.raises(FlowvoError, match="raft-small needs"):
        create_estimator("raft-small")


def test_color_wheel_directions():
    flow = np.array([[[1.0, 0.0], [-1.0, 0.0], [0.0, 0.0], [np.nan, 0.0]]], np.float32)
    colours = flow_to_color(flow, max_magnitude_px=1.0)
    assert tuple(colours[0, 2]) == (255, 255, 255)  # no motion is white
    assert tuple(colours[0, 3]) == (0, 0, 0)  # invalid is black
    assert colours[0, 0, 0] == 255 and colours[0, 0, 1] < 10 and colours[0, 0, 2] < 10  # right is red
    assert colours[0, 1, 2] > 200 and colours[0, 1, 0] < 10  # left is cyan-blue
    assert color_legend(51).shape == (51, 51, 3)
