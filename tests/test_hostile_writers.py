"""Hostile round two, the writers: nothing overwritten without --force (bench --json onto ground truth or
an earlier file, synth over a user's pose file), --force replacing only with a finished result, one
writer per output folder (the lock), empty and non-UTF-8 names, and OS errors naming the file."""

import errno
import fcntl
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hostile import cli, refused, tree_digest

from flowvo.io.outputs import LOCK_NAME, output_lock, staged_outputs
from flowvo.synth.dataset import synthesize

SRC = Path(__file__).resolve().parents[1] / "src"


@pytest.fixture(scope="module")
def data(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("writers") / "data"
    synthesize(root, ["00"], seed=3, frames=8, scale=0.15, workers=1)
    return root


def classical(data: Path, out: Path, *extra: object) -> list[object]:
    return ["run", "--data", data, "--sequence", "00", "--out", out, "--method", "classical", *extra]


def bench(data: Path, *extra: object) -> list[object]:
    return ["bench", "--data", data, "--sequence", "00", "--methods", "classical", "--frames", "3", "--repeat", "1",
            *extra]


def test_bench_json_never_writes_into_the_dataset(data, capsys):
    before = tree_digest(data)
    refused(capsys, *bench(data, "--json", data / "poses" / "00.txt", "--force"), says=("inside the dataset", "00.txt"))
    assert tree_digest(data) == before


def test_bench_json_refuses_an_earlier_file_without_force_before_running(data, tmp_path, capsys):
    earlier = tmp_path / "rows.json"
    earlier.write_text("{}")
    err = refused(capsys, *bench(data, "--json", earlier), says=("earlier result", "--force"))
    assert "rows.json" in err and earlier.read_text() == "{}"
    assert cli(capsys, *bench(data, "--json", earlier, "--force"))[0] == 0 and "rows" in earlier.read_text()


def test_synth_force_never_replaces_a_users_own_pose_file(tmp_path, capsys):
    (tmp_path / "poses").mkdir()
    (tmp_path / "poses" / "00.txt").write_text("my own poses\n")
    refused(capsys, "synth", "--out", tmp_path, "--frames", "3", "--scale", "0.1", "--workers", "1", "--force",
            says=("sequence 00 not written by flowvo synth", "--force"))
    assert (tmp_path / "poses" / "00.txt").read_text() == "my own poses\n"


def test_synth_writes_beside_other_sequences_of_a_dataset(data, tmp_path, capsys):
    root = tmp_path / "d"
    synthesize(root, ["00"], seed=3, frames=3, scale=0.1, workers=1)
    kept = tree_digest(root / "sequences" / "00")
    assert cli(capsys, "synth", "--out", root, "--sequences", "01", "--frames", "3", "--scale", "0.1",
               "--workers", "1")[0] == 0
    assert tree_digest(root / "sequences" / "00") == kept and (root / "poses" / "01.txt").is_file()


@pytest.mark.parametrize("out", ["", b"bad\xff".decode("utf-8", "surrogateescape")])
def test_run_refuses_an_empty_or_non_utf8_out(data, out, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    refused(capsys, *classical(data, out), says="--out")
    assert list(tmp_path.iterdir()) == []


def test_non_utf8_inputs_are_refused_before_opencv_sees_them(tmp_path, capsys):
    name = os.fsdecode(bytes(tmp_path) + b"/v\xff.mp4")
    refused(capsys, "run", "--video", name, "--fx", "100", "--fy", "100", "--cx", "50", "--cy", "40", "--out",
            tmp_path / "o", says="not UTF-8")
    refused(capsys, "run", "--data", os.fsdecode(bytes(tmp_path) + b"/d\xff"), "--sequence", "00", "--out",
            tmp_path / "o", says="not UTF-8")


def test_a_second_writer_of_the_same_folder_is_refused_naming_the_holder(data, tmp_path, capsys):
    out = tmp_path / "r"
    out.mkdir()
    with output_lock(out):
        err = refused(capsys, *classical(data, out), says=("being written by process", str(os.getpid()), "r"))
        assert LOCK_NAME in err
    assert sorted(p.name for p in out.iterdir()) == []  # refused before writing; the lock file went with it
    assert cli(capsys, *classical(data, out))[0] == 0 and not (out / LOCK_NAME).exists()


def test_the_lock_is_held_by_a_running_process_and_dies_with_it(tmp_path):
    out = tmp_path / "r"
    out.mkdir()
    holder = subprocess.Popen([sys.executable, "-c", "import sys, time; from flowvo.io.outputs import output_lock\n"
                               f"with output_lock({str(out)!r}):\n    print('held', flush=True); time.sleep(60)"],
                              stdout=subprocess.PIPE, text=True, env={**os.environ, "PYTHONPATH": str(SRC)})
    try:
        assert holder.stdout.readline().strip() == "held"
        with open(out / LOCK_NAME) as handle, pytest.raises(BlockingIOError):
            fcntl.flock(handle.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    finally:
        holder.kill()
        holder.wait()
    with output_lock(out):  # a killed holder leaves the file, never the lock
        pass


def test_two_runs_into_one_folder_at_once_one_wins_whole(data, tmp_path):
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    runs = [subprocess.Popen([sys.executable, "-m", "flowvo.cli", *map(str, classical(data, tmp_path / "r")), "-q"],
                             stderr=subprocess.PIPE, text=True, env=env) for _ in range(2)]
    results = [(run.wait(), run.stderr.read()) for run in runs]
    assert sorted(code for code, _ in results) == [0, 2]
    assert any("being written by" in err or "earlier result" in err for _, err in results)
    assert len(np.loadtxt(tmp_path / "r" / "00.txt")) == 8


def test_force_keeps_the_earlier_result_until_the_new_one_is_complete(data, tmp_path, capsys, monkeypatch):
    out = tmp_path / "r"
    assert cli(capsys, *classical(data, out))[0] == 0
    before = tree_digest(out)
    from flowvo.drive import run as pipeline

    def fail(*args, **kwargs):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), None)

    monkeypatch.setattr(pipeline, "write_tum_trajectory", fail)
    code, _, err = cli(capsys, *classical(data, out, "--force"))
    assert code == 2 and "No space left on device" in err
    assert tree_digest(out) == before  # every earlier file and eval_00/ exactly as they were


def test_force_removes_a_stale_entry_only_after_the_new_result(tmp_path):
    out = tmp_path / "r"
    (out / "eval_00").mkdir(parents=True)
    (out / "eval_00" / "metrics.json").write_text("old")
    (out / "00.txt").write_text("old")
    with staged_outputs(out, ["00.txt", "eval_00"]) as staging:
        (staging / "00.txt").write_text("new")
        assert (out / "eval_00" / "metrics.json").read_text() == "old"  # still there while writing
    assert (out / "00.txt").read_text() == "new" and not (out / "eval_00").exists()
    assert sorted(p.name for p in out.iterdir()) == ["00.txt"]  # no staging debris


def test_disk_full_during_a_write_names_the_file(tmp_path, capsys, monkeypatch):
    from flowvo.io.atomic import write_text_atomic

    def full(fd):  # a full disk shows at the flush or fsync of a write, which names no file
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(os, "fsync", full)
    with pytest.raises(OSError) as caught:
        write_text_atomic(tmp_path / "x.json", "{}")
    assert caught.value.filename == str(tmp_path / "x.json")
    assert list(tmp_path.iterdir()) == []
