"""Hostile names and output folders: sequence names that are paths, --out in the dataset, in a file, in an
unwritable place, over an earlier result; synth into a non-empty folder. Nothing may be written outside
--out, into the dataset, or over an earlier result without --force."""

import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest
from hostile import cli, refused, tree_digest

from flowvo.kitti.sequence import KittiSequence
from flowvo.model.checkpoint import packaged_model_path
from flowvo.synth import sequence_writer
from flowvo.synth.dataset import synthesize

PATH_NAMES = ["D/sequences/00", "../00", "..", ".", "", "00/..", "/tmp/00", "-00", ".hidden", "a b", "00\\x",
              "sequences/00", "00//"]


@pytest.fixture(scope="module")
def data(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("names") / "data"
    synthesize(root, ["00"], seed=1, frames=12, scale=0.1, workers=1)
    return root


def classical(data: Path, out: Path, *extra: object, sequence: str = "00") -> list[object]:
    return ["run", "--data", data, "--sequence", sequence, "--out", out, "--method", "classical", *extra]


@pytest.mark.parametrize("name", PATH_NAMES)
def test_run_refuses_a_sequence_name_that_is_a_path(data, tmp_path, capsys, name):
    before = tree_digest(data)
    refused(capsys, *classical(data, tmp_path / "out", sequence=name), says="sequence name")
    assert not (tmp_path / "out").exists() and tree_digest(data) == before


@pytest.mark.parametrize("command", [
    ["flow", "--data", "{data}", "--sequence", "../00"],
    ["synth", "--out", "{tmp}/s", "--sequences", "../../escape", "--frames", "2"],
    ["synth", "--out", "{tmp}/s", "--sequences", "00", "00", "--frames", "2"],
    ["train", "--data", "{data}", "--train", "../00", "--val", "00", "--out", "{tmp}/t"],
    ["bench", "--data", "{data}", "--sequence", "00/../00"],
    ["demo", "--data", "{data}", "--sequence", "../00", "--out", "{tmp}/d"],
], ids=["flow", "synth-escape", "synth-twice", "train", "bench", "demo"])
def test_every_command_refuses_path_names_before_writing(data, tmp_path, capsys, command):
    args = [str(a).format(data=data, tmp=tmp_path) for a in command]
    refused(capsys, *args, says="sequence")
    assert list(tmp_path.iterdir()) == []  # nothing written, inside or outside --out


def test_tab_completed_name_is_the_sequence(data, tmp_path, capsys):
    code, out, _ = cli(capsys, *classical(data, tmp_path / "out", sequence="00/"))
    assert code == 0 and "ATE" in out  # evaluated: the ground truth was found
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["00.tum", "00.txt", "eval_00", "run.json",
                                                                      "timing.json"]


def test_numeric_names_are_zero_padded_everywhere(tmp_path, capsys):
    synthesize(tmp_path / "d", ["9"], frames=2, scale=0.1, workers=1)
    assert (tmp_path / "d" / "sequences" / "09").is_dir() and (tmp_path / "d" / "poses" / "09.txt").is_file()
    assert len(KittiSequence(tmp_path / "d", "009")) == 2


@pytest.mark.parametrize("inside", [".", "sequences", "sequences/00", "poses", "runs/new"])
def test_run_refuses_an_out_inside_the_dataset(data, capsys, inside):
    before = tree_digest(data)
    refused(capsys, *classical(data, data / inside), says="inside the dataset")
    assert tree_digest(data) == before  # the ground truth poses/00.txt survives


def test_run_refuses_an_out_that_links_into_the_dataset(data, tmp_path, capsys):
    (tmp_path / "link").symlink_to(data / "poses", target_is_directory=True)
    before = tree_digest(data)
    refused(capsys, *classical(data, tmp_path / "link"), says="inside the dataset")
    assert tree_digest(data) == before


def test_a_file_as_out_or_above_out_is_refused(data, tmp_path, capsys):
    (tmp_path / "f").write_text("mine")
    refused(capsys, *classical(data, tmp_path / "f"), says=("--out is a file", str(tmp_path / "f")))
    refused(capsys, *classical(data, tmp_path / "f" / "sub"), says=("cannot be written", "Not a directory"))
    assert (tmp_path / "f").read_text() == "mine"


@pytest.mark.skipif(not Path("/sys/kernel").is_dir(), reason="needs Linux sysfs")
def test_an_unwritable_out_is_refused_before_any_work(data, capsys):
    refused(capsys, *classical(data, "/sys/flowvo_cannot_write_here"), says="cannot be written")


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
def test_a_read_only_out_is_refused(data, tmp_path, capsys):
    (tmp_path / "ro").mkdir()
    (tmp_path / "ro").chmod(0o555)
    try:
        refused(capsys, *classical(data, tmp_path / "ro"), says=("cannot be written", "ermission denied"))
    finally:
        (tmp_path / "ro").chmod(0o755)


def test_an_earlier_run_is_kept_without_force_and_replaced_with_it(data, tmp_path, capsys):
    out = tmp_path / "out"
    assert cli(capsys, *classical(data, out))[0] == 0
    before = tree_digest(out)
    refused(capsys, *classical(data, out), says=("holds an earlier result", "--force"))
    assert tree_digest(out) == before
    assert cli(capsys, *classical(data, out, "--force"))[0] == 0


def test_force_removes_a_stale_evaluation_when_ground_truth_is_gone(data, tmp_path, capsys):
    out = tmp_path / "out"
    assert cli(capsys, *classical(data, out))[0] == 0
    assert (out / "eval_00" / "metrics.json").is_file()
    no_gt = tmp_path / "no_gt"
    shutil.copytree(data, no_gt)
    (no_gt / "poses" / "00.txt").unlink()
    assert cli(capsys, *classical(no_gt, out, "--scale-from", "height", "--force"))[0] == 0
    assert not (out / "eval_00").exists()
    assert "metrics" not in json.loads((out / "run.json").read_text())


def test_a_users_own_file_of_the_same_name_is_not_overwritten(data, tmp_path, capsys):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "00.txt").write_text("my own predictions\n")
    refused(capsys, *classical(data, out), says="00.txt")
    assert (out / "00.txt").read_text() == "my own predictions\n"


@pytest.mark.parametrize("command, existing", [
    (["eval", "--gt", "{gt}", "--pred", "{gt}", "--out", "{out}"], "metrics.json"),
    (["flow", "--data", "{data}", "--sequence", "00", "--scale", "1", "--cache", "{tmp}/c", "--visualize", "{out}"],
     "flow_000000.png"),
    (["export", "--model", "{model}", "--out", "{out}/slim.pt", "--format", "slim"], "slim.pt"),
], ids=["eval", "flow-pictures", "export"])
def test_other_writers_refuse_an_earlier_result_without_force(data, tmp_path, capsys, command, existing):
    out = tmp_path / "out"
    args = [a.format(gt=data / "poses" / "00.txt", data=data, out=out, tmp=tmp_path, model=packaged_model_path())
            for a in command]
    assert cli(capsys, *args)[0] == 0 and (out / existing).is_file()
    before = tree_digest(out)
    refused(capsys, *args, says=("earlier result", existing))
    assert tree_digest(out) == before
    assert cli(capsys, *args, "--force")[0] == 0


def test_export_over_its_own_model_is_refused_even_with_force(tmp_path, capsys):
    model = Path(shutil.copy(packaged_model_path(), tmp_path / "model.pt"))
    before = model.read_bytes()
    refused(capsys, "export", "--model", model, "--out", model, "--format", "slim", "--force",
            says="--out is the --model file")
    assert model.read_bytes() == before


def test_export_to_a_folder_name_is_refused(tmp_path, capsys):
    refused(capsys, "export", "--model", packaged_model_path(), "--out", tmp_path, "--format", "slim",
            says="is a folder")


def test_flow_pictures_are_not_written_into_the_dataset(data, tmp_path, capsys):
    before = tree_digest(data)
    refused(capsys, "flow", "--data", data, "--sequence", "00", "--scale", "1", "--cache", tmp_path, "--visualize",
            data / "vis", says="inside the dataset")
    assert tree_digest(data) == before


def synth(out: Path, *extra: object) -> list[object]:
    return ["synth", "--out", out, "--sequences", "00", "--frames", "6", "--scale", "0.1", "--workers", "1", *extra]


def test_synth_refuses_a_non_empty_folder(tmp_path, capsys):
    (tmp_path / "notes.txt").write_text("keep me")
    refused(capsys, *synth(tmp_path), says=("is not empty", "--force"))
    assert [p.name for p in tmp_path.iterdir()] == ["notes.txt"]


def test_synth_over_another_rendering_refuses_then_force_leaves_a_consistent_dataset(tmp_path, capsys):
    assert cli(capsys, *synth(tmp_path, "--seed", "1"))[0] == 0
    synthesize(tmp_path, ["01"], frames=3, scale=0.1, workers=1, force=True)  # another sequence, kept
    old_frames = tree_digest(tmp_path / "sequences" / "00" / "image_0")
    kept = tree_digest(tmp_path / "sequences" / "01")
    refused(capsys, *synth(tmp_path, "--seed", "2", "--frames", "9"),
            says=("sequence(s) 00 rendered differently", "--force"))
    assert tree_digest(tmp_path / "sequences" / "00" / "image_0") == old_frames
    assert cli(capsys, *synth(tmp_path, "--seed", "2", "--frames", "9", "--force"))[0] == 0
    sequence = KittiSequence(tmp_path, "00")  # the reader's own checks: frames, times and poses agree
    assert len(sequence) == len(sequence.poses) == len(sequence.times_s) == 9
    fresh = tmp_path / "fresh"
    synthesize(fresh, ["00"], seed=2, frames=9, scale=0.1, workers=1)
    assert tree_digest(tmp_path / "sequences" / "00") == tree_digest(fresh / "sequences" / "00")
    np.testing.assert_array_equal(np.loadtxt(tmp_path / "poses" / "00.txt"), np.loadtxt(fresh / "poses" / "00.txt"))
    assert tree_digest(tmp_path / "sequences" / "01") == kept


def test_synth_does_not_resume_frames_of_an_earlier_renderer(tmp_path, capsys, monkeypatch):
    """The same spec rendered by an earlier renderer generation is another rendering: refused, then replaced whole."""
    monkeypatch.setattr(sequence_writer, "RENDERER_GENERATION", sequence_writer.RENDERER_GENERATION - 1)
    assert cli(capsys, *synth(tmp_path))[0] == 0
    monkeypatch.undo()
    refused(capsys, *synth(tmp_path), says=("sequence(s) 00 rendered differently", "--force"))
    assert cli(capsys, *synth(tmp_path, "--force"))[0] == 0
    fresh = tmp_path / "fresh"
    synthesize(fresh, ["00"], frames=6, scale=0.1, workers=1)
    assert tree_digest(tmp_path / "sequences" / "00") == tree_digest(fresh / "sequences" / "00")


def test_synth_force_never_replaces_a_sequence_it_did_not_write(tmp_path, capsys):
    real = tmp_path / "sequences" / "00" / "image_0"
    real.mkdir(parents=True)
    (real / "000000.png").write_bytes(b"a real camera frame")
    refused(capsys, *synth(tmp_path, "--force"), says="not written by flowvo synth")
    assert (real / "000000.png").read_bytes() == b"a real camera frame"


def test_synth_resumes_the_same_command_without_force(tmp_path, capsys):
    assert cli(capsys, *synth(tmp_path))[0] == 0
    complete = tree_digest(tmp_path)
    for frame in sorted((tmp_path / "sequences" / "00" / "image_0").iterdir())[3:]:
        frame.unlink()  # as if killed after three frames
    assert cli(capsys, *synth(tmp_path))[0] == 0
    assert tree_digest(tmp_path) == complete
