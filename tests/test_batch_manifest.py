"""Manifests (CSV, JSON Lines): per-drive settings read and checked; every bad line is one error naming
the manifest and the line."""

from pathlib import Path

import pytest

from flowvo.batch.manifest import read_manifest
from flowvo.errors import FlowvoError


@pytest.fixture
def place(tmp_path) -> Path:
    (tmp_path / "drives").mkdir()
    (tmp_path / "drives" / "a.mp4").write_bytes(b"")
    (tmp_path / "calib.txt").write_text("P0: 1 0 0 0 0 1 0 0 0 0 1 0\n")
    return tmp_path


def test_csv_lines_resolve_paths_against_the_manifest_and_parse_numbers(place):
    manifest = place / "m.csv"
    manifest.write_text("path,kind,fx,fy,cx,cy,camera_height_m,method,topic\n"
                        "drives/a.mp4,video,700,700.5,320,240,1.3,flowvo-geometry,\n"
                        "\n"
                        f"{place / 'drives' / 'a.mp4'},,,,,,,,\n")
    first, second = read_manifest(manifest)
    assert first.path == place / "drives" / "a.mp4" and first.kind == "video"
    assert first.settings == {"fx": 700.0, "fy": 700.5, "cx": 320.0, "cy": 240.0, "camera_height_m": 1.3,
                              "method": "flowvo-geometry"}
    assert second.settings == {} and second.where == f"{manifest}:4"


def test_json_lines_take_numbers_text_and_null(place):
    manifest = place / "m.jsonl"
    manifest.write_text('{"path": "drives/a.mp4", "calib": "calib.txt", "camera_height_m": "1.5"}\n\n'
                        '{"path": "drives", "name": "x", "method": null}\n')
    first, second = read_manifest(manifest)
    assert first.settings == {"calib": str(place / "calib.txt"), "camera_height_m": 1.5}
    assert second.path == place / "drives" and second.name == "x" and second.settings == {}


@pytest.mark.parametrize("suffix, text, expected", [
    (".csv", "path,colour\ndrives/a.mp4,red\n", r"m.csv:1: unknown column\(s\) 'colour'"),
    (".jsonl", '{"path": "drives/a.mp4"}\n{"path": "drives/a.mp4", "speed": 3}\n', r"m.jsonl:2: unknown column"),
    (".csv", "path\ndrives/b.mp4\n", r"m.csv:2: path 'drives/b.mp4' not found"),
    (".csv", "path,calib\ndrives/a.mp4,nowhere.txt\n", r"m.csv:2: calib 'nowhere.txt' not found"),
    (".csv", "path,fx\ndrives/a.mp4,seven\n", r"m.csv:2: fx must be a number, got 'seven'"),
    (".csv", "path,camera_height_m\ndrives/a.mp4,-1\n", r"m.csv:2: camera_height_m must be finite and > 0"),
    (".jsonl", '{"path": "drives/a.mp4", "cx": NaN}\n', r"m.jsonl:1: cx must be finite and >= 0"),
    (".jsonl", '{"path": "drives/a.mp4", "fx": true}\n', r"m.jsonl:1: fx must be a number"),
    (".csv", "path,method\ndrives/a.mp4,magic\n", r"m.csv:2: method 'magic' is not one of"),
    (".csv", "path,kind\ndrives/a.mp4,lidar\n", r"m.csv:2: kind 'lidar' is not one of"),
    (".csv", "path,sequence,fx\ndrives,00,700\n", r"m.csv:2: fx: fx, fy, cx, cy go together; missing fy, cx, cy"),
    (".csv", "path,camera_height_m\ndrives/a.mp4,100\n", r"m.csv:2: camera_height_m: camera height must be .* "
                                                          r"got 100.0"),
    (".csv", "path,name\ndrives/a.mp4,../up\n", r"m.csv:2: drive name '../up' is a path"),
    (".csv", "path\ndrives/a.mp4,extra\n", r"m.csv:2: 2 fields for the header's 1 columns"),
    (".csv", "path\n\n", r"m.csv: manifest lists no drives"),
    (".csv", "", r"m.csv: manifest is empty"),
    (".csv", "kind\nvideo\n", r"m.csv:1: no 'path' column"),
    (".csv", "path,path\ndrives/a.mp4,drives/a.mp4\n", r"m.csv:1: column\(s\) path given twice"),
    (".csv", "path,method\n,classical\n", r"m.csv:2: 'path' is empty"),
    (".jsonl", '["drives/a.mp4"]\n', r"m.jsonl:1: expected one JSON object per line"),
    (".jsonl", '{"path": \n', r"m.jsonl:1: not a JSON object"),
])
def test_each_bad_line_is_one_error_naming_the_manifest_and_line(place, suffix, text, expected):
    manifest = place / f"m{suffix}"
    manifest.write_text(text)
    with pytest.raises(FlowvoError, match=expected) as caught:
        read_manifest(manifest)
    assert "\n" not in str(caught.value)
