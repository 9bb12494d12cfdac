"""From the inputs of ``flowvo batch`` to drives with unique output names.

An input is a path or a glob (expanded here, so quoting it keeps the shell's argument limit away) or a
manifest (:mod:`flowvo.batch.manifest`). Under a path, drives are found as follows:

- a KITTI dataset root (a folder holding ``sequences/``): each ``sequences/NAME`` with an ``image_0`` folder;
- a KITTI sequence folder (``ROOT/sequences/NAME`` with ``image_0``): that sequence;
- a ROS 2 bag folder (holding ``metadata.yaml``): that bag;
- a file whose suffix is a video's (:data:`VIDEO_SUFFIXES`) or a bag's (``.bag``, ``.mcap``, ``.db3``);
- any other folder: searched recursively (names starting with '.' and the batch's own output are skipped).

Names: each drive's path relative to its input's base folder (an input folder, the folder of an input
file, the fixed part of a glob, a manifest's folder), with '__' for '/', the ``sequences`` level of a KITTI
root dropped, and characters other than letters, digits, '.', '_' and '-' replaced by '_': e.g.
``day1__cam.mp4`` under an input folder holding ``day1/cam.mp4``, or ``07`` for sequence 07 of an input
KITTI root. Inputs whose base folders share their parent (``kitti/`` and ``videos/`` side by side) are
named from that common folder: ``kitti__07``, ``videos__cam.mp4``. Inputs from apart in the tree name their
drives from the folder above each base, so ``/home/me/data/kitti_clips`` and ``/tmp/videos`` give
``kitti_clips__07`` and ``videos__cam.mp4``, not ``home__me__data__kitti_clips__07`` (where that makes two
drives share a name, from the common folder of all bases). The names stay the same when
drives are added under the same inputs, so a nightly rerun resumes. Two different drives that would still
share a name (also when only letter case differs) are refused. Entries that are neither files nor folders
(FIFOs, sockets, devices, broken links) are skipped while searching, and refused when named as an input.
"""

from __future__ import annotations

import glob
import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from flowvo.batch.manifest import ManifestLine, is_manifest, read_manifest
from flowvo.batch.spec import Drive
from flowvo.errors import FlowvoError
from flowvo.io.outputs import is_inside
from flowvo.kitti.sequence import sequence_name
from flowvo.sources.rosbag import BAG_FILE_SUFFIXES

VIDEO_SUFFIXES = (".mp4", ".m4v", ".mov", ".avi", ".mkv", ".webm", ".mpg", ".mpeg", ".ts", ".mts", ".m2ts",
                  ".wmv", ".flv", ".3gp", ".h264", ".h265", ".hevc")
_GLOB_CHARS = re.compile(r"[*?\[]")
_UNSAFE = re.compile(r"[^A-Za-z0-9._-]")


@dataclass(frozen=True)
class _Found:
    """A drive found on disk: ``kind``, ``path`` (absolute), KITTI ``sequence``, and ``key``, the path its
    name is made from (for KITTI: ROOT/sequences/NAME)."""

    kind: str
    path: Path
    sequence: str | None
    key: Path


def discover_drives(inputs: list[str], exclude: str | Path | None = None) -> list[Drive]:
    """The drives under ``inputs`` (paths, globs, manifests), in input order, each once, uniquely named.

    ``exclude``: a folder never searched (the batch output, which holds MCAP files of its own).
    Raises a one-line FlowvoError for an input that does not exist, matches nothing or holds no drive, a
    bad manifest, the same drive given twice with different settings, or two drives sharing a name.
    """
    if not inputs:
        raise FlowvoError("no input: give folders, video files, bags, globs or a manifest (CSV or JSON Lines)")
    entries: list[tuple[_Found, Path, ManifestLine | None]] = []  # found drive, its naming base, manifest line
    for text in inputs:
        if is_manifest(text):
            for line in read_manifest(text):
                found = _search(line.path, exclude, line.where, explicit=True)
                found = _select(found, line)
                entries += [(item, Path(text).absolute().parent, line) for item in found]
            continue
        paths, base, explicit = _expand(text)
        found = [item for path in paths for item in _search(path, exclude, text, explicit)]
        if not found:
            raise FlowvoError("no drives found (looked for KITTI sequences with image_0, video files "
                              f"{', '.join(VIDEO_SUFFIXES[:4])} ..., bags {', '.join(BAG_FILE_SUFFIXES)})", text)
        entries += [(item, base, None) for item in found]
    return _name(_deduplicate(entries))


def _expand(text: str) -> tuple[list[Path], Path, bool]:
    """The paths an input names, the folder names are made relative to, and whether the input named the
    path itself (not a glob)."""
    path = Path(text).expanduser()
    if path.exists():
        absolute = path.absolute()
        is_single_drive = absolute.is_file() or _is_sequence_folder(absolute) or _is_ros2_bag(absolute)
        base = absolute.parent.parent if _is_sequence_folder(absolute) else absolute.parent if is_single_drive \
            else absolute
        return [absolute], base, True
    if not _GLOB_CHARS.search(text):
        raise FlowvoError("not found", text)
    matches = sorted(glob.glob(os.path.expanduser(text), recursive=True))
    if not matches:
        raise FlowvoError("matches nothing", text)
    fixed = []
    for part in path.parts:
        if _GLOB_CHARS.search(part):
            break
        fixed.append(part)
    return [Path(match).absolute() for match in matches], Path(*fixed).absolute() if fixed else Path.cwd(), False


def _search(path: Path, exclude: str | Path | None, where: str, explicit: bool) -> list[_Found]:
    """Drives at or under ``path``; an ``explicit`` file that is no drive is an error, a found one is skipped
    (so is anything that is neither a file nor a folder: a FIFO would block its reader for ever)."""
    if not path.is_file() and not path.is_dir():
        if explicit:
            raise FlowvoError(f"{path} is neither a file nor a folder (a FIFO, a socket, a device or a broken "
                              "link)", where)
        return []
    if path.is_file():
        suffix = path.suffix.lower()
        if suffix in VIDEO_SUFFIXES:
            return [_Found("video", path, None, path)]
        if suffix in BAG_FILE_SUFFIXES:
            return [_Found("bag", path, None, path)]
        if explicit:
            raise FlowvoError(f"{path} is neither a video ({', '.join(VIDEO_SUFFIXES[:4])} ...), a bag "
                              f"({', '.join(BAG_FILE_SUFFIXES)}) nor a manifest (.csv, .jsonl)", where)
        return []
    found: list[_Found] = []
    visited: set[Path] = set()
    pending = [path]
    while pending:
        folder = pending.pop()
        if folder.resolve() in visited or (exclude is not None and is_inside(folder, exclude)):
            continue
        visited.add(folder.resolve())
        if (folder / "sequences").is_dir():
            found += [_Found("kitti", folder, sequence_name(sequence.name), sequence)
                      for sequence in (folder / "sequences").iterdir()
                      if (sequence / "image_0").is_dir() and not sequence.name.startswith(".")]
        elif _is_sequence_folder(folder):
            found.append(_Found("kitti", folder.parent.parent, sequence_name(folder.name), folder))
        elif _is_ros2_bag(folder):
            found.append(_Found("bag", folder, None, folder))
        else:
            for child in folder.iterdir():
                if child.name.startswith("."):
                    continue
                if child.is_dir():
                    pending.append(child)
                else:
                    found += _search(child, exclude, where, explicit=False)
    return sorted(found, key=lambda item: item.key)


def _is_sequence_folder(folder: Path) -> bool:
    return folder.parent.name == "sequences" and (folder / "image_0").is_dir()


def _is_ros2_bag(folder: Path) -> bool:
    return folder.is_dir() and (folder / "metadata.yaml").is_file()


def _select(found: list[_Found], line: ManifestLine) -> list[_Found]:
    """The drives of one manifest line: of its ``kind``, its ``sequence`` only, exactly one when it names it."""
    if line.kind is not None:
        found = [item for item in found if item.kind == line.kind]
    if line.sequence is not None:
        wanted = sequence_name(line.sequence)
        found = [item for item in found if item.kind == "kitti" and item.sequence == wanted]
    if not found:
        what = f"KITTI sequence {line.sequence}" if line.sequence is not None else f"{line.kind or 'drive'}"
        raise FlowvoError(f"no {what} found at {line.path}", line.where)
    if line.name is not None and len(found) > 1:
        raise FlowvoError(f"'name' {line.name} given for {len(found)} drives found at {line.path}; "
                          "a named line must find exactly one (add 'sequence' or point at one file)", line.where)
    return found


def _deduplicate(entries: list[tuple[_Found, Path, ManifestLine | None]]
                 ) -> list[tuple[_Found, Path, ManifestLine | None]]:
    """Each drive once: the same drive found again (overlapping inputs) with the same settings is dropped;
    with other settings it is an error."""
    first: dict[tuple[str, Path, str | None], tuple[_Found, Path, ManifestLine | None]] = {}
    for entry in entries:
        item, _, line = entry
        identity = (item.kind, item.path.resolve(), item.sequence)
        if identity not in first:
            first[identity] = entry
            continue
        earlier = first[identity][2]
        if _settings(earlier) != _settings(line) or (earlier and earlier.name) != (line and line.name):
            places = " and ".join(where for where in (_where(earlier), _where(line)))
            raise FlowvoError(f"drive {_describe(item)} is given twice with different settings ({places})")
    return list(first.values())


def _settings(line: ManifestLine | None) -> dict[str, Any]:
    return {} if line is None else line.settings


def _where(line: ManifestLine | None) -> str:
    return "the command line" if line is None else line.where


def _describe(item: _Found) -> str:
    return f"{item.path} sequence {item.sequence}" if item.kind == "kitti" else str(item.path)


def _name(entries: list[tuple[_Found, Path, ManifestLine | None]]) -> list[Drive]:
    bases = {base for _, base, _ in entries}
    root = Path(os.path.commonpath([str(base) for base in bases]))

    def named(item: _Found, base: Path, line: ManifestLine | None, from_bases: bool) -> str:
        if line is not None and line.name is not None:
            return line.name
        return drive_name(item.key, (base.parent if base.parent != base else base) if from_bases else root)

    from_bases = any(base != root and base.parent != root for base in bases)  # inputs from apart in the tree
    if from_bases:
        names = [named(item, base, line, True).casefold() for item, base, line in entries]
        from_bases = len(set(names)) == len(names)
    drives: list[Drive] = []
    taken: dict[str, _Found] = {}
    for item, base, line in entries:
        name = named(item, base, line, from_bases)
        if name.casefold() in taken:
            other = taken[name.casefold()]
            raise FlowvoError(f"drives {_describe(other)} and {_describe(item)} would both be written to "
                              f"drives/{name}: give them different names in a manifest ('name' column)")
        taken[name.casefold()] = item
        drives.append(Drive(name, item.kind, str(item.path), item.sequence, dict(_settings(line))))
    return drives


def drive_name(key: Path, root: Path) -> str:
    """The output name of the drive at ``key`` (KITTI: ROOT/sequences/NAME) relative to the folder ``root``."""
    parts = list(key.relative_to(root).parts) if key != root else [key.name]
    if len(parts) >= 2 and parts[-2] == "sequences":
        del parts[-2]
    safe = [_UNSAFE.sub("_", part) for part in parts if part]
    name = "__".join(safe) or "drive"
    return "_" + name[1:] if name[0] in ".-" else name
