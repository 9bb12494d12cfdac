"""NAME_steps.csv: one row per step, in frame order, exactly what the window recorded."""

import pytest

from flowvo.drive.steps_csv import HEADER, read_steps_csv, write_steps_csv
from flowvo.odometry.scale_window import StepRecord


def test_each_step_is_a_row_and_a_missing_sigma_an_empty_cell(tmp_path):
    records = [StepRecord(0.1, 1.25, 0.0123456789, "road+ratio"), StepRecord(0.2, 0.0, None, "standstill")]
    path = tmp_path / "00_steps.csv"
    write_steps_csv(path, records, frames=3)
    assert path.read_text().splitlines() == [HEADER, "1,0.100000000,1.250000,0.012346,road+ratio",
                                             "2,0.200000000,0.000000,,standstill"]
    assert read_steps_csv(path) == [StepRecord(0.1, 1.25, 0.012346, "road+ratio"), records[1]]


def test_a_file_of_another_layout_is_not_read_as_step_records(tmp_path):
    path = tmp_path / "00.txt"
    path.write_text("1 0 0 0 0 1 0 0 0 0 1 0\n")
    with pytest.raises(ValueError, match="not a step records file"):
        read_steps_csv(path)


def test_records_that_do_not_match_the_frames_are_refused(tmp_path):
    with pytest.raises(ValueError, match="one per step"):
        write_steps_csv(tmp_path / "00_steps.csv", [StepRecord(0.1, 1.0, 0.01, "road")], frames=3)
    assert not (tmp_path / "00_steps.csv").exists()
