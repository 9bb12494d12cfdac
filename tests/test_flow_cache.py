import numpy as np
import pytest

from flowvo.cli import main
from flowvo.errors import FlowvoError
from flowvo.flow import cache as cache_module
from flowvo.flow.cache import FlowCache
from flowvo.flow.registry import create_estimator
from flowvo.kitti.sequence import KittiSequence
from flowvo.synth.dataset import synthesize


@pytest.fixture(scope="module")
def sequence(tmp_path_factory):
    root = tmp_path_factory.mktemp("flowdata")
    synthesize(root, ["00"], seed=1, frames=12, scale=0.25, workers=1)
    return KittiSequence(root, "00")


def test_resume_after_interruption_equals_uninterrupted_run(sequence, tmp_path, monkeypatch):
    monkeypatch.setattr(cache_module, "CHUNK_PAIRS", 4)
    estimator = create_estimator("dis-fast")
    full = FlowCache(tmp_path / "a", sequence, "dis-fast", 0.5, estimator.params())
    full.compute(estimator)
    interrupted = FlowCache(tmp_path / "b", sequence, "dis-fast", 0.5, estimator.params())
    interrupted.compute(estimator, stop_after_chunks=1)  # the "crash": only the first chunk exists
    (interrupted.directory / ".chunk_000001.npy.x1y2.tmp").write_bytes(b"half-written")  # debris of the kill
    assert interrupted.missing_chunks() == [1, 2]
    resumed = FlowCache(tmp_path / "b", sequence, "dis-fast", 0.5, estimator.params())
    timing = resumed.compute(estimator)
    assert timing["pairs"] == 7
    np.testing.assert_array_equal(resumed.read_range(0, 11), full.read_range(0, 11))
    assert resumed.read(5).shape == (47, 155, 2)


def test_cache_made_with_other_parameters_is_recomputed_not_reused(sequence, tmp_path):
    estimator = create_estimator("dis-fast")
    FlowCache(tmp_path, sequence, "dis-fast", 0.5, estimator.params()).compute(estimator)
    other = FlowCache(tmp_path, sequence, "dis-fast", 0.5, {"preset": "dis-ultrafast"})
    assert "made with params=" in other.stale_reason and other.missing_chunks() == [0]
    with pytest.raises(FlowvoError, match="chunk unusable"):
        other.read(0)
    timing = other.compute(create_estimator("dis-ultrafast"))
    assert timing["pairs"] == 11 and "params" in timing["discarded"]
    reopened = FlowCache(tmp_path, sequence, "dis-fast", 0.5, {"preset": "dis-ultrafast"})
    assert reopened.stale_reason is None and reopened.complete


def test_flow_cli_computes_and_visualises(sequence, tmp_path, capsys):
    code = main(["flow", "--data", str(sequence.root), "--sequence", "00", "--cache", str(tmp_path / "c"),
                 "--visualize", str(tmp_path / "v"), "--gif", "-q"])
    assert code == 0
    assert "11 pairs" in capsys.readouterr().out
    assert (tmp_path / "v" / "flow_000010.png").is_file() and (tmp_path / "v" / "flow.gif").is_file()
