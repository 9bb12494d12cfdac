"""Kills and signals: Ctrl-C (SIGINT) ends in one line and exit 130 with resumable state kept; OS errors
(disk full, permissions) end in one line naming the path; a resumed run completes what was cut off."""

import csv
import errno
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from hostile import cli, interruptible, tree_digest

from flowvo.flow import cache as cache_module
from flowvo.flow.classical import DisFlow
from flowvo.kitti.sequence import KittiSequence
from flowvo.model import train as train_module
from flowvo.synth.dataset import synthesize

SRC = Path(__file__).resolve().parents[1] / "src"


@pytest.fixture(scope="module")
def data(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("signals") / "data"
    synthesize(root, ["00", "01"], seed=7, frames=12, scale=0.15, workers=1)
    return root


def test_sigint_during_synth_exits_130_with_one_line_and_the_rerun_resumes(tmp_path):
    args = [sys.executable, "-m", "flowvo.cli", "synth", "--out", str(tmp_path / "d"), "--frames", "400",
            "--scale", "0.1", "--workers", "2", "-q"]
    env = {**os.environ, "PYTHONPATH": f"{SRC}{os.pathsep}{os.environ.get('PYTHONPATH', '')}"}
    process = interruptible(args, env)
    frames = tmp_path / "d" / "sequences" / "00" / "image_0"

    def whole_frames() -> int:  # pathlib's "*" matches the hidden file a frame is written to before its rename
        return sum(not path.name.startswith(".") for path in frames.glob("*.png"))

    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and whole_frames() < 5 and process.poll() is None:
        time.sleep(0.02)
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 130, err
    assert err == "flowvo synth: interrupted (resumable state kept)\n"
    kept = whole_frames()
    assert 5 <= kept < 400 and not list(frames.glob(".*"))  # whole frames only, no temporary debris
    resumed = subprocess.run(args, capture_output=True, text=True, env=env, timeout=120)
    assert resumed.returncode == 0, resumed.stderr  # the same command resumes: no --force needed
    assert len(KittiSequence(tmp_path / "d", "00")) == 400


def test_debris_of_a_killed_writer_is_not_read_as_a_frame(data, tmp_path):
    copy = tmp_path / "d"
    synthesize(copy, ["00"], seed=7, frames=4, scale=0.15, workers=1)
    (copy / "sequences/00/image_0/.000002.k1ll.png").write_bytes(b"half a frame")  # SIGKILL mid-write
    assert len(KittiSequence(copy, "00")) == 4


def interrupt_after(monkeypatch, owner, name: str, calls: int) -> None:
    """Make ``owner.name`` raise KeyboardInterrupt (as Ctrl-C would) on call number ``calls``."""
    original = getattr(owner, name)
    count = [0]

    def wrapper(*args, **kwargs):
        count[0] += 1
        if count[0] == calls:
            raise KeyboardInterrupt
        return original(*args, **kwargs)

    monkeypatch.setattr(owner, name, wrapper)


def test_ctrl_c_during_flow_keeps_finished_chunks_and_the_rerun_completes_them(data, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(cache_module, "CHUNK_PAIRS", 4)
    args = ["flow", "--data", data, "--sequence", "00", "--scale", "1", "--cache", tmp_path]
    interrupt_after(monkeypatch, DisFlow, "estimate", 6)  # in the second chunk
    assert cli(capsys, *args) == (130, "", "flowvo flow: interrupted (resumable state kept)\n")
    assert sorted(p.name for p in tmp_path.rglob("chunk_*.npy")) == ["chunk_000000.npy"]
    monkeypatch.undo()
    monkeypatch.setattr(cache_module, "CHUNK_PAIRS", 4)
    code, out, _ = cli(capsys, *args)
    assert code == 0 and "computed 7 pairs" in out  # only what was missing


def test_ctrl_c_during_training_keeps_the_last_epoch_and_resume_completes(data, tmp_path, capsys, monkeypatch):
    out = tmp_path / "run"
    args = ["train", "--data", data, "--train", "00", "--val", "01", "--out", out, "--epochs", "2",
            "--batch-size", "8", "--width", "0.125", "--flow-method", "dis-ultrafast", "--flow-scale", "1"]
    interrupt_after(monkeypatch, train_module, "_validation_metrics", 2)  # during epoch 2
    code, _, err = cli(capsys, *args)
    assert (code, err) == (130, "flowvo train: interrupted (resumable state kept)\n")
    assert [row["epoch"] for row in csv.DictReader(open(out / "log.csv"))] == ["1"]
    monkeypatch.undo()
    code, _, _ = cli(capsys, "train", "--out", out, "--resume")
    assert code == 0
    assert [row["epoch"] for row in csv.DictReader(open(out / "log.csv"))] == ["1", "2"]


@pytest.mark.parametrize("error", [errno.ENOSPC, errno.EACCES, errno.EROFS])
def test_an_os_error_while_writing_is_one_line_naming_the_path(data, tmp_path, capsys, monkeypatch, error):
    import tempfile

    def failing_mkstemp(*args, dir=None, **kwargs):
        raise OSError(error, os.strerror(error), dir)

    monkeypatch.setattr(tempfile, "mkstemp", failing_mkstemp)
    code, _, err = cli(capsys, "run", "--data", data, "--sequence", "00", "--out", tmp_path / "r",
                       "--method", "classical")
    assert code == 2 and err == f"flowvo run: error: {tmp_path / 'r'}: {os.strerror(error)}\n"


def test_nothing_is_left_half_written_when_a_write_fails(data, tmp_path, capsys, monkeypatch):
    out = tmp_path / "r"
    assert cli(capsys, "run", "--data", data, "--sequence", "00", "--out", out, "--method", "classical")[0] == 0
    before = tree_digest(out)
    real_replace = os.replace

    def fail_on_run_json(source, target):
        if str(target).endswith("run.json"):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(target))
        real_replace(source, target)

    monkeypatch.setattr(os, "replace", fail_on_run_json)
    code, _, err = cli(capsys, "run", "--data", data, "--sequence", "00", "--out", out, "--method", "classical",
                       "--force")
    assert code == 2 and "run.json: No space left on device" in err
    assert not [p for p in out.rglob("*") if p.name.endswith(".tmp") or p.name.startswith(".")]
    assert tree_digest(out) == before  # the earlier result is whole: --force replaces only with a finished one


def test_ctrl_c_while_the_command_line_imports_is_one_line(monkeypatch, capsys):
    import builtins

    from flowvo import entry

    real_import = builtins.__import__

    def interrupted(name, *args, **kwargs):
        if name == "flowvo.cli":
            raise KeyboardInterrupt
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", interrupted)
    assert entry.main() == 130
    assert capsys.readouterr().err == "flowvo: interrupted while starting\n"
