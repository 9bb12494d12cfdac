"""Finding drives under the inputs of ``flowvo batch`` and naming their output folders: names that do not
collide, stay the same as the fleet grows, and refusals with one line."""

from pathlib import Path

import pytest

from flowvo.batch.discover import discover_drives
from flowvo.errors import FlowvoError


def touch(path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(b"")
    return path


def kitti(root: Path, *sequences: str) -> Path:
    for sequence in sequences:
        (root / "sequences" / sequence / "image_0").mkdir(parents=True)
    return root


def names(drives) -> list[str]:
    return [drive.name for drive in drives]


def test_two_videos_of_one_name_in_different_folders_get_different_names(tmp_path):
    touch(tmp_path / "fleet" / "day1" / "drive.mp4")
    touch(tmp_path / "fleet" / "day2" / "drive.mp4")
    touch(tmp_path / "fleet" / "day2" / "drive.MOV")
    touch(tmp_path / "fleet" / "day2" / "notes.txt")  # not a drive: skipped where found
    drives = discover_drives([str(tmp_path / "fleet")])
    assert names(drives) == ["day1__drive.mp4", "day2__drive.MOV", "day2__drive.mp4"]
    assert [drive.kind for drive in drives] == ["video"] * 3
    assert drives[0].path == str(tmp_path / "fleet" / "day1" / "drive.mp4")
    inputs = [str(tmp_path / "fleet" / "day1" / "drive.mp4"), str(tmp_path / "fleet" / "day2" / "drive.mp4")]
    assert names(discover_drives(inputs)) == ["day1__drive.mp4", "day2__drive.mp4"]


def test_kitti_roots_sequence_folders_and_bags_are_drives(tmp_path):
    kitti(tmp_path / "data" / "kitti", "00", "07")
    (tmp_path / "data" / "kitti" / "sequences" / "09").mkdir()  # no image_0: not a sequence
    touch(tmp_path / "data" / "ros2_drive" / "metadata.yaml")
    touch(tmp_path / "data" / "ros2_drive" / "ros2_drive_0.mcap")  # part of the bag folder, not a bag itself
    touch(tmp_path / "data" / "old.bag")
    touch(tmp_path / "data" / ".hidden" / "x.mp4")
    drives = discover_drives([str(tmp_path / "data")])
    assert [(d.name, d.kind, d.sequence) for d in drives] == [
        ("kitti__00", "kitti", "00"), ("kitti__07", "kitti", "07"), ("old.bag", "bag", None),
        ("ros2_drive", "bag", None)]
    assert drives[0].path == str(tmp_path / "data" / "kitti")
    assert names(discover_drives([str(tmp_path / "data" / "kitti")])) == ["00", "07"]
    assert names(discover_drives([str(tmp_path / "data" / "kitti" / "sequences" / "07")])) == ["07"]


def test_a_glob_names_drives_from_its_fixed_part_so_names_stay_when_the_fleet_grows(tmp_path):
    touch(tmp_path / "fleet" / "2024-05-01" / "cam.mp4")
    pattern = str(tmp_path / "fleet" / "*" / "*.mp4")
    assert names(discover_drives([pattern])) == ["2024-05-01__cam.mp4"]
    touch(tmp_path / "fleet" / "2024-05-02" / "cam.mp4")
    assert names(discover_drives([pattern])) == ["2024-05-01__cam.mp4", "2024-05-02__cam.mp4"]


def test_the_batch_output_is_never_searched(tmp_path):
    touch(tmp_path / "a.mp4")
    touch(tmp_path / "out" / "drives" / "x.bag" / "x.mcap")  # flowvo's own MCAP output of an earlier batch
    assert names(discover_drives([str(tmp_path)], exclude=tmp_path / "out")) == ["a.mp4"]


def test_a_drive_found_twice_is_run_once(tmp_path):
    touch(tmp_path / "v" / "a.mp4")
    assert names(discover_drives([str(tmp_path / "v"), str(tmp_path / "v" / "a.mp4"), str(tmp_path / "v" / "*")])) \
        == ["a.mp4"]


def test_names_that_collide_after_cleaning_are_refused(tmp_path):
    touch(tmp_path / "a b" / "x.mp4")
    touch(tmp_path / "a_b" / "x.mp4")
    with pytest.raises(FlowvoError, match=r"x.mp4 and .*x.mp4 would both be written to drives/a_b__x.mp4"):
        discover_drives([str(tmp_path)])


def test_names_differing_only_in_case_collide(tmp_path):
    touch(tmp_path / "A.mp4")
    touch(tmp_path / "a.mp4")
    with pytest.raises(FlowvoError, match="would both be written"):
        discover_drives([str(tmp_path)])


@pytest.mark.parametrize("make, expected", [
    (lambda p: [str(p / "absent")], "absent: not found"),
    (lambda p: [str(p / "nothing*")], "nothing*: matches nothing"),
    (lambda p: [str(touch(p / "notes.txt"))], "is neither a video"),
    (lambda p: [str((p / "empty").mkdir() or p / "empty")], "no drives found"),
    (lambda p: [], "no input"),
])
def test_inputs_without_drives_are_refused(tmp_path, make, expected):
    with pytest.raises(FlowvoError, match=expected.replace("*", r"\*")):
        discover_drives(make(tmp_path))


def test_a_manifest_selects_sequences_names_drives_and_carries_their_settings(tmp_path):
    kitti(tmp_path / "kitti", "00", "01")
    touch(tmp_path / "v" / "cam.mp4")
    calib = touch(tmp_path / "calib.txt")
    calib.write_text("P0: 700 0 600 0 0 700 180 0 0 0 1 0\n")  # the manifest reads it, as --calib would
    manifest = tmp_path / "fleet.csv"
    manifest.write_text("path,sequence,name,method,camera_height_m,calib\n"
                        "kitti,01,,classical,,\n"
                        f"v/cam.mp4,,front,,1.4,{calib.name}\n")
    drives = discover_drives([str(manifest)])
    assert [(d.name, d.kind, d.sequence) for d in drives] == [("kitti__01", "kitti", "01"), ("front", "video", None)]
    assert drives[0].settings == {"method": "classical"}
    assert drives[1].settings == {"camera_height_m": 1.4, "calib": str(calib)}


def test_the_same_drive_with_two_settings_is_refused(tmp_path):
    touch(tmp_path / "cam.mp4")
    manifest = tmp_path / "m.jsonl"
    manifest.write_text('{"path": "cam.mp4", "method": "classical"}\n')
    with pytest.raises(FlowvoError, match=r"given twice with different settings \(.*m.jsonl:1 and the command line"):
        discover_drives([str(manifest), str(tmp_path / "cam.mp4")])


def test_a_named_manifest_line_must_find_one_drive(tmp_path):
    kitti(tmp_path / "kitti", "00", "01")
    manifest = tmp_path / "m.csv"
    manifest.write_text("path,name\nkitti,both\n")
    with pytest.raises(FlowvoError, match=r"m.csv:2: 'name' both given for 2 drives"):
        discover_drives([str(manifest)])
