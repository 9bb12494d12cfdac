import json
import subprocess
import sys

import numpy as np
import pytest
import torch

from flowvo import geometry as g
from flowvo.cli import main
from flowvo.errors import FlowvoError
from flowvo.model.checkpoint import load_model, packaged_model_path, save_checkpoint
from flowvo.model.config import ModelConfig
from flowvo.model.deployable import DeployableOdometry
from flowvo.model.export import export_onnx, export_torchscript
from flowvo.model.network import OdometryNet
from flowvo.model.preprocess import Normalization, mirror_input

pytest.importorskip("onnx")
pytest.importorskip("onnxruntime")
from flowvo.model.onnx_runtime import OnnxOdometry  # noqa: E402

PHYSICAL_ATOL = 1e-4  # metres and radians


def random_flows_px(model, batch: int, seed: int = 0) -> np.ndarray:
    """Flows (B, 2K, h, w) float32 of the magnitude the network sees (std = its flow_std_px)."""
    rng = np.random.default_rng(seed)
    shape = (batch, 2 * model.stack, *model.input_hw)
    return (rng.standard_normal(shape) * float(model.flow_std_px)).astype(np.float32)


@pytest.fixture(scope="module")
def packaged(tmp_path_factory):
    """The packaged model as a PyTorch module and exported by the CLI (default --model) to ONNX."""
    out = tmp_path_factory.mktemp("export") / "default.onnx"
    assert main(["export", "--format", "onnx", "--out", str(out), "-q"]) == 0
    return DeployableOdometry.from_checkpoint(packaged_model_path()), out


def tiny_checkpoint(path, head: str, stack: int):
    torch.manual_seed(3)
    config = ModelConfig(width=0.125, input_hw=(32, 96), head=head, stack=stack, fc_units=32)
    means, stds = np.linspace(0.1, 0.6, config.outputs).tolist(), np.linspace(0.2, 0.05, config.outputs).tolist()
    normalization = Normalization(tuple(means), tuple(stds), 3.0)
    save_checkpoint(path, {"model_config": {**config.__dict__, "input_hw": list(config.input_hw)},
                           "normalization": normalization.to_dict(), "model_state": OdometryNet(config).state_dict(),
                           "flow_size_hw": [64, 200], "train_config": {"flow_method": "dis-fast", "flow_scale": 0.5}})
    return path


def test_deployable_matches_the_normalise_mirror_average_rule_on_the_packaged_model(packaged):
    model, _ = packaged
    network, normalization, _ = load_model(packaged_model_path())
    flows_px = random_flows_px(model, 4)
    with torch.no_grad():  # the rule before DeployableOdometry: normalise, both passes, float64 de-normalise
        inputs = torch.from_numpy(flows_px) / normalization.flow_std_px
        both = normalization.denormalize(network(torch.cat([inputs, mirror_input(inputs)])).numpy().astype(np.float64))
    expected = 0.5 * (both[:4] + g.mirror_targets(both[4:], "planar"))
    np.testing.assert_allclose(model.predict(flows_px), expected, atol=1e-6)
    assert model.output_names == ("distance_m", "heading_rad")
    assert model.input_hw == (96, 320) and model.stack == 1 and model.head == "planar"
    assert all(p.dtype == torch.float32 for p in model.parameters())  # the slim checkpoint is float16


def test_onnx_runtime_and_pytorch_agree_on_physical_outputs_at_any_batch_size(packaged):
    model, onnx_path = packaged
    runtime = OnnxOdometry(onnx_path)
    for batch in (1, 5):
        flows_px = random_flows_px(model, batch, seed=batch)
        onnx_motion = runtime.predict(flows_px)
        assert onnx_motion.shape == (batch, 2) and onnx_motion.dtype == np.float64
        np.testing.assert_allclose(onnx_motion, model.predict(flows_px), atol=PHYSICAL_ATOL)
    assert (runtime.input_hw, runtime.stack, runtime.head, runtime.output_names) == (
        model.input_hw, model.stack, model.head, model.output_names)


def test_export_describes_input_output_and_training_flow_beside_the_model(packaged):
    _, onnx_path = packaged
    description = json.loads(onnx_path.with_name(onnx_path.name + ".json").read_text())
    assert description["input"]["name"] == "flow_px" and description["input"]["shape"] == ["batch", 2, 96, 320]
    assert description["input"]["units"] == "px"
    assert description["output"]["components"] == ["distance_m", "heading_rad"]
    assert description["output"]["units"] == ["m", "rad"]
    assert description["head"] == "planar" and description["symmetric"] is True
    assert description["flow"]["flow_size_hw"] == [188, 620]
    assert OnnxOdometry(onnx_path).description == description  # the same JSON travels inside the .onnx


@pytest.mark.parametrize("symmetric", [True, False])
def test_se3_stacked_model_exports_agree_with_pytorch_onnx_and_torchscript(tmp_path, symmetric):
    checkpoint = tiny_checkpoint(tmp_path / "se3.pt", "se3", stack=2)
    model = DeployableOdometry.from_checkpoint(checkpoint, symmetric)
    flows_px = random_flows_px(model, 3)
    expected = model.predict(flows_px)
    onnx_path, _ = export_onnx(checkpoint, tmp_path / "se3.onnx", symmetric)
    np.testing.assert_allclose(OnnxOdometry(onnx_path).predict(flows_px), expected, atol=PHYSICAL_ATOL)
    script_path, _ = export_torchscript(checkpoint, tmp_path / "se3.ts", symmetric)
    scripted = torch.jit.load(str(script_path))
    with torch.no_grad():
        np.testing.assert_allclose(scripted(torch.from_numpy(flows_px)).numpy(), expected, atol=PHYSICAL_ATOL)
    assert model.output_names == ("tx_m", "ty_m", "tz_m", "rx_rad", "ry_rad", "rz_rad")


def test_symmetric_module_mirrors_its_output_by_the_geometry_rule(tmp_path):
    model = DeployableOdometry.from_checkpoint(tiny_checkpoint(tmp_path / "se3.pt", "se3", stack=2))
    flows_px = torch.from_numpy(random_flows_px(model, 2))
    np.testing.assert_allclose(model.predict(mirror_input(flows_px)), g.mirror_targets(model.predict(flows_px), "se3"),
                               atol=1e-6)


def test_torchscript_export_of_the_packaged_model_agrees_with_pytorch(packaged, tmp_path):
    model, _ = packaged
    assert main(["export", "--out", str(tmp_path / "m.ts"), "-q"]) == 0
    scripted = torch.jit.load(str(tmp_path / "m.ts"))
    flows_px = random_flows_px(model, 2)
    with torch.no_grad():
        np.testing.assert_allclose(scripted(torch.from_numpy(flows_px)).numpy(), model.predict(flows_px),
                                   atol=PHYSICAL_ATOL)


def test_missing_onnx_package_is_one_clear_error(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "onnx", None)  # import onnx now raises ImportError
    with pytest.raises(FlowvoError, match=r"ONNX export needs the onnx package: pip install 'flowvo\[export\]'"):
        export_onnx(packaged_model_path(), tmp_path / "m.onnx")
    assert not (tmp_path / "m.onnx").exists()


def test_onnx_odometry_refuses_missing_and_foreign_files(tmp_path):
    with pytest.raises(FlowvoError, match="absent.onnx: ONNX model not found"):
        OnnxOdometry(tmp_path / "absent.onnx")
    (tmp_path / "text.onnx").write_text("not a model\n")
    with pytest.raises(FlowvoError, match="text.onnx: cannot load as an ONNX model"):
        OnnxOdometry(tmp_path / "text.onnx")


def test_onnx_runtime_path_imports_no_torch():
    code = "import sys, flowvo.model.onnx_runtime; assert 'torch' not in sys.modules, 'torch imported'"
    subprocess.run([sys.executable, "-c", code], check=True)
