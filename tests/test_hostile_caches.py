"""Hostile caches: truncated, foreign, bit-flipped or stale flow chunks, damaged metadata, the default
location (outside the dataset) and an unwritable cache folder. A damaged chunk is detected and
recomputed; it never runs silently and never crashes."""

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from hostile import cli, refused, tree_digest

from flowvo.errors import FlowvoError
from flowvo.flow import cache as cache_module
from flowvo.flow.cache import FlowCache
from flowvo.flow.cache_root import default_cache_root
from flowvo.flow.registry import create_estimator
from flowvo.kitti.sequence import KittiSequence
from flowvo.synth.dataset import synthesize


@pytest.fixture(scope="module")
def data(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("caches") / "data"
    synthesize(root, ["00"], seed=4, frames=12, scale=0.2, workers=1)
    return root


@pytest.fixture
def small_chunks(monkeypatch):
    monkeypatch.setattr(cache_module, "CHUNK_PAIRS", 4)  # 11 pairs: chunks of 4, 4 and 3


@pytest.fixture
def filled(data, tmp_path, small_chunks) -> tuple[FlowCache, np.ndarray]:
    """A complete cache at scale 0.5 and its flow."""
    cache = FlowCache(tmp_path / "cache", KittiSequence(data, "00"), "dis-fast", 0.5,
                      create_estimator("dis-fast").params())
    cache.compute(create_estimator("dis-fast"))
    return cache, cache.read_range(0, 11)


def reopen(cache: FlowCache) -> FlowCache:
    return FlowCache(cache.directory.parents[1], cache.sequence, "dis-fast", 0.5, create_estimator("dis-fast").params())


def truncate(path: Path) -> None:
    path.write_bytes(path.read_bytes()[:1000])


def flip_one_value(path: Path) -> None:
    flows = np.load(path)
    flows[1, 3, 3, 0] += 7.0
    np.save(path, flows)  # same size and shape: only the checksum can tell


DAMAGE = {
    "truncated": (truncate, "bytes, meta.json records"),
    "deleted": (lambda p: p.unlink(), "missing"),
    "not npy": (lambda p: p.write_bytes(b"\x00" * p.stat().st_size), "not a readable .npy file"),
    "bit flipped": (flip_one_value, None),
}


@pytest.mark.parametrize("damage", DAMAGE)
def test_a_damaged_chunk_is_detected_and_recomputed(filled, damage):
    cache, flows = filled
    spoil, problem = DAMAGE[damage]
    spoil(cache.chunk_path(1))
    cache = reopen(cache)
    if problem is not None:  # cheap checks see it, and reading it is refused instead of crashing or lying
        assert problem in cache.chunk_problem(1)
        with pytest.raises(FlowvoError, match="chunk unusable"):
            cache.read_range(0, 11)
    assert cache.missing_chunks(verify_checksums=True) == [1]
    timing = cache.compute(create_estimator("dis-fast"))
    assert timing["pairs"] == 4 and timing["replaced"] == (damage != "deleted")
    np.testing.assert_array_equal(cache.read_range(0, 11), flows)


def test_a_chunk_of_another_scale_is_detected_and_recomputed(data, filled, tmp_path):
    cache, flows = filled
    other = FlowCache(tmp_path / "other", cache.sequence, "dis-fast", 1.0, create_estimator("dis-fast").params())
    other.compute(create_estimator("dis-fast"))
    shutil.copy(other.chunk_path(0), cache.chunk_path(0))
    cache = reopen(cache)
    assert cache.chunk_problem(0) is not None and cache.missing_chunks() == [0]
    cache.compute(create_estimator("dis-fast"))
    np.testing.assert_array_equal(cache.read_range(0, 11), flows)


@pytest.mark.parametrize("meta", ["{ not json", "[]", '{"method": "dis-fast"}'])
def test_damaged_or_old_metadata_makes_the_cache_recomputed(filled, meta):
    cache, flows = filled
    cache.meta_path.write_text(meta)
    cache = reopen(cache)
    assert cache.stale_reason is not None and cache.missing_chunks() == [0, 1, 2]
    timing = cache.compute(create_estimator("dis-fast"))
    assert timing["pairs"] == 11 and "meta.json" in timing["discarded"]
    np.testing.assert_array_equal(cache.read_range(0, 11), flows)


def test_a_sound_complete_cache_is_only_read_so_it_may_be_read_only(filled):
    cache, _ = filled
    before = {path: path.stat().st_mtime_ns for path in cache.directory.iterdir()}
    timing = reopen(cache).compute(create_estimator("dis-fast"))
    assert timing["pairs"] == 0 and timing["replaced"] == 0 and timing["discarded"] is None
    assert {path: path.stat().st_mtime_ns for path in cache.directory.iterdir()} == before


def test_damaged_timing_is_ignored_not_fatal(filled):
    cache, _ = filled
    cache.timing_path.write_text('{"read_s": "fast"}')
    assert reopen(cache).recorded_timing() is None


def test_frames_rendered_again_make_the_cache_stale(data, tmp_path, capsys, small_chunks):
    copy = Path(shutil.copytree(data, tmp_path / "data"))
    args = ["flow", "--data", copy, "--sequence", "00", "--cache", tmp_path / "c"]
    assert cli(capsys, *args)[0] == 0
    synthesize(copy, ["00"], seed=5, frames=12, scale=0.2, workers=1, force=True)  # other frames, same size
    code, out, _ = cli(capsys, *args)
    assert code == 0 and "discarded an earlier flow cache: it was made with frames_sha256" in out


def test_default_cache_is_outside_the_dataset_and_keyed_by_its_path(data, tmp_path, capsys, private_user_cache):
    twin = Path(shutil.copytree(data, tmp_path / "data"))  # same folder name, another dataset
    before = tree_digest(data)
    for root in (data, twin):
        assert cli(capsys, "flow", "--data", root, "--sequence", "00")[0] == 0
    assert tree_digest(data) == before  # nothing written into the dataset
    first, second = default_cache_root(data), default_cache_root(twin)
    assert first != second and first.name.startswith("data-") and second.name.startswith("data-")
    assert first.parent == private_user_cache / "flowvo" / "flow"
    assert (first / "00" / "dis-fast_s0.5" / "meta.json").is_file()


def test_a_damaged_chunk_is_recomputed_to_the_clean_bytes(data, tmp_path, capsys):
    args = ["flow", "--data", data, "--sequence", "00", "--cache", tmp_path / "c"]
    assert cli(capsys, *args)[0] == 0
    chunk = next((tmp_path / "c").rglob("chunk_000000.npy"))
    clean = chunk.read_bytes()
    truncate(chunk)
    assert cli(capsys, *args)[0] == 0
    assert chunk.read_bytes() == clean
    meta = json.loads(next((tmp_path / "c").rglob("meta.json")).read_text())
    assert meta["chunks"]["000000"]["bytes"] == chunk.stat().st_size


def test_a_file_as_cache_folder_is_one_line(data, tmp_path, capsys):
    (tmp_path / "c").write_text("not a folder")
    refused(capsys, "flow", "--data", data, "--sequence", "00", "--cache", tmp_path / "c",
            says=("cannot create the flow cache folder", "writable --cache"))
