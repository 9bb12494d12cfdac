import numpy as np
import pytest
import torch

from flowvo import geometry as g
from flowvo.errors import FlowvoError
from flowvo.model.checkpoint import check_compatible, load_model, save_checkpoint
from flowvo.model.config import ModelConfig, TrainConfig
from flowvo.model.data import OdometryDataset
from flowvo.model.network import OdometryNet, flops_per_frame, parameter_count
from flowvo.model.preprocess import Normalization, mirror_input, resize_flow
from flowvo.projection import flow_from_depth


@pytest.mark.parametrize("head, outputs", [("planar", 2), ("se3", 6)])
@pytest.mark.parametrize("stack", [1, 3])
@pytest.mark.parametrize("input_hw", [(64, 192), (96, 320)])
def test_network_shapes_for_every_configuration(head, outputs, stack, input_hw):
    model = OdometryNet(ModelConfig(width=0.125, input_hw=input_hw, head=head, stack=stack))
    assert model(torch.zeros(4, 2 * stack, *input_hw)).shape == (4, outputs)


def test_thesis_network_has_ten_convolutions_with_leaky_relu_and_dropout():
    model = OdometryNet(ModelConfig(width=1.0, input_hw=(384, 1280)))
    convolutions = [m for m in model.modules() if isinstance(m, torch.nn.Conv2d)]
    assert [c.out_channels for c in convolutions] == [64, 128, 256, 256, 512, 512, 512, 512, 1024, 1024]
    assert [c.stride[0] for c in convolutions] == [2, 2, 2, 1, 2, 1, 2, 1, 2, 1]
    assert all(m.negative_slope == 0.1 for m in model.modules() if isinstance(m, torch.nn.LeakyReLU))
    assert sum(isinstance(m, torch.nn.LeakyReLU) for m in model.modules()) == 11
    assert model.fc[1].out_features == 1024 and model.fc[3].p == 0.5
    small = OdometryNet(ModelConfig())
    assert parameter_count(small) == 4_128_978
    assert flops_per_frame(small) == pytest.approx(0.2515e9, rel=1e-3)


def level_scene_depth(size_hw, K):
    """Depth of a flat ground plane 1.65 m below the camera and sky above: left-right symmetric."""
    h, w = size_hw
    y = (np.arange(h)[:, None] - K[1, 2]) / K[1, 1]
    depth = np.where(y > 0.01, 1.65 / np.maximum(y, 1e-9), np.inf)
    return np.broadcast_to(depth, (h, w)).copy()


def test_mirrored_flow_of_a_right_turn_is_the_flow_of_the_left_turn():
    size_hw = (60, 161)
    K = np.array([[100.0, 0, 80.0], [0, 100.0, 20.0], [0, 0, 1]])  # principal point on the centre column
    right_turn = g.chain_planar(np.array([[1.2, 0.05]]))
    left_turn = np.stack([g.MIRROR_X @ p @ g.MIRROR_X for p in right_turn])
    depth = level_scene_depth(size_hw, K)
    flow_right, _ = flow_from_depth(depth, K, g.invert_se3(right_turn[1]) @ right_turn[0])
    flow_left, _ = flow_from_depth(depth, K, g.invert_se3(left_turn[1]) @ left_turn[0])
    mirrored = mirror_input(torch.from_numpy(flow_right.transpose(2, 0, 1)))
    np.testing.assert_allclose(mirrored.numpy(), flow_left.transpose(2, 0, 1), atol=1e-4)
    np.testing.assert_allclose(g.planar_targets(left_turn), g.mirror_targets(g.planar_targets(right_turn), "planar"))


def test_dataset_mirrors_every_sample():
    flows = [torch.randn(5, 2, 8, 12).half()]
    targets = [np.column_stack([np.linspace(0.5, 1.0, 5), np.linspace(-0.1, 0.1, 5)])]
    normalization = Normalization((0.0, 0.0), (1.0, 1.0), 1.0)
    dataset = OdometryDataset(flows, targets, normalization, "planar", stack=2, mirror=True)
    assert len(dataset) == 10
    x, y = dataset[3]
    xm, ym = dataset[8]
    assert x.shape == (4, 8, 12)
    torch.testing.assert_close(xm[0], -torch.flip(x[0], dims=[-1]))
    torch.testing.assert_close(xm[1], torch.flip(x[1], dims=[-1]))
    torch.testing.assert_close(ym, y * torch.tensor([1.0, -1.0]))
    x0, _ = dataset[0]
    torch.testing.assert_close(x0[:2], x0[2:])  # pair 0 repeats itself to fill the stack


def test_mirror_about_an_off_centre_principal_point_after_centring():
    size_hw = (60, 161)
    K = np.array([[100.0, 0, 70.0], [0, 100.0, 20.0], [0, 0, 1]])  # principal point 10 px left of centre
    right_turn = g.chain_planar(np.array([[1.2, 0.05]]))
    left_turn = np.stack([g.MIRROR_X @ p @ g.MIRROR_X for p in right_turn])
    depth = level_scene_depth(size_hw, K)
    flow_right, _ = flow_from_depth(depth, K, g.invert_se3(right_turn[1]) @ right_turn[0])
    flow_left, _ = flow_from_depth(depth, K, g.invert_se3(left_turn[1]) @ left_turn[0])
    centred_right = resize_flow(flow_right, (60, 141), cx_px=70.0)
    centred_left = resize_flow(flow_left, (60, 141), cx_px=70.0)
    np.testing.assert_allclose(mirror_input(torch.from_numpy(centred_right)).numpy(), centred_left, atol=1e-4)
    plain_flip = mirror_input(torch.from_numpy(flow_right.transpose(2, 0, 1))).numpy()
    assert np.abs(plain_flip - flow_left.transpose(2, 0, 1)).max() > 0.1  # why the centring is needed


def test_resize_flow_rescales_values_with_the_size():
    flow = np.zeros((40, 100, 2), np.float32)
    flow[..., 0], flow[..., 1] = 10.0, -4.0
    resized = resize_flow(flow, (20, 25))
    assert resized.shape == (2, 20, 25)
    np.testing.assert_allclose(resized[0], 2.5)
    np.testing.assert_allclose(resized[1], -2.0)


def test_tiny_network_overfits_twenty_samples():
    torch.manual_seed(0)
    config = ModelConfig(width=0.125, input_hw=(32, 64), dropout=0.0)
    model = OdometryNet(config)
    inputs = torch.randn(20, 2, 32, 64)
    targets = torch.randn(20, 2)
    optimizer = torch.optim.Adam(model.parameters(), lr=1e-3)
    for _ in range(200):
        loss = ((model(inputs) - targets) ** 2).mean()
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
    assert loss.item() < 0.02  # from ~1.0 (measured 0.009)


def test_checkpoint_of_other_architecture_is_refused(tmp_path):
    config = ModelConfig(width=0.125, input_hw=(64, 192))
    model = OdometryNet(config)
    save_checkpoint(tmp_path / "m.pt", {
        "model_config": {**config.__dict__, "input_hw": list(config.input_hw)},
        "normalization": Normalization((0, 0), (1, 1), 1.0).to_dict(), "model_state": model.state_dict(),
    })
    loaded, _, state = load_model(tmp_path / "m.pt")
    assert loaded.config == config
    with pytest.raises(FlowvoError, match=r"m.pt: checkpoint has a different architecture: input_hw=\(64, 192\)"):
        check_compatible(state, ModelConfig(width=0.125, input_hw=(96, 320)), tmp_path / "m.pt")
    torch.save({"weights": 1}, tmp_path / "foreign.pt")
    with pytest.raises(FlowvoError, match="foreign.pt: not a flowvo odometry checkpoint"):
        load_model(tmp_path / "foreign.pt")


def test_train_config_round_trips_through_yaml_and_rejects_unknown_keys(tmp_path):
    config = TrainConfig(data="d", epochs=3, model=ModelConfig(head="se3", stack=2))
    config.save_yaml(tmp_path / "c.yaml")
    again = TrainConfig.from_yaml(tmp_path / "c.yaml")
    assert again == config
    (tmp_path / "bad.yaml").write_text("epochs: 3\nlearning_rat: 0.1\n")
    with pytest.raises(FlowvoError, match="bad.yaml: unknown training option.*learning_rat"):
        TrainConfig.from_yaml(tmp_path / "bad.yaml")


def test_symmetric_inference_cancels_a_constant_heading_offset():
    from flowvo.model.deployable import DeployableOdometry

    torch.manual_seed(1)
    model = OdometryNet(ModelConfig(width=0.125, input_hw=(32, 96), fc_units=64))
    normalization = Normalization((1.0, 0.0), (0.5, 0.02), 2.0)
    inputs = torch.randn(6, 2, 32, 96) * normalization.flow_std_px  # flow in pixels

    def predict(flow_px, symmetric=True):
        return DeployableOdometry(model, normalization, symmetric).predict(flow_px)

    before = predict(inputs)
    with torch.no_grad():
        model.head.bias[1] += 3.0  # a constant heading offset of 3 std = 0.06 rad
    after = predict(inputs)
    plain = predict(inputs, symmetric=False)
    np.testing.assert_allclose(after[:, 1], before[:, 1], atol=1e-6)
    assert np.abs(plain[:, 1] - after[:, 1]).min() > 0.05
    # a mirrored input gives the mirrored motion exactly
    mirrored = predict(torch.stack([mirror_input(x) for x in inputs]))
    np.testing.assert_allclose(mirrored, g.mirror_targets(after, "planar"), atol=1e-6)
