"""Where results go: names that are names (not paths), and output folders checked before any work.

Rules every writing sub-command follows (through :func:`prepare_output_dir`):

- ``--out`` is a folder: an existing file there is refused, so is a folder that cannot be created or
  written (read-only, permission denied), before any long computation starts;
- results never go into the dataset (``--out`` at or below ``--data`` is refused), so a prediction can
  never be read back as ground truth or overwrite it;
- an earlier result is never overwritten silently: if any file the command would write exists, it is
  refused unless the user passes ``--force``; even then nothing is removed up front: every file is
  written under a temporary name and renamed over the old one (:mod:`flowvo.io.atomic`), folders are swapped
  whole once complete (:func:`replace_folder`), and what the new result lacks is removed last
  (:func:`remove_stale`), so an interrupted or failed run leaves the earlier result intact;
- one writer at a time: :func:`output_lock` holds ``.flowvo.lock`` in the folder for the whole command
  and refuses a second one, naming the holder's PID.

Imports neither torch nor OpenCV (``flowvo eval`` uses it).
"""

from __future__ import annotations

import fcntl
import os
import re
import shutil
import tempfile
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import IO

from flowvo.errors import FlowvoError

_NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9._-]*$")
LOCK_NAME = ".flowvo.lock"  # in an output folder while a command writes it (holds the writer's PID)


def validate_name(name: str, what: str = "sequence") -> str:
    """``name`` checked to be a plain name (``00``, ``seqA``), never a path.

    One trailing ``/`` (left by shell tab completion, ``00/``) is dropped. Refused: empty names, path
    separators, ``.`` and ``..``, and characters other than letters, digits, ``.``, ``_`` and ``-`` (or a
    leading ``.`` or ``-``).
    """
    text = str(name)
    if text.endswith("/"):
        text = text[:-1]
    if not text:
        raise FlowvoError(f"{what} name is empty")
    if "/" in text or "\\" in text or text in (".", ".."):
        raise FlowvoError(f"{what} name {name!r} is a path; give a name such as 00 (a folder of DATA/sequences)")
    if not _NAME.match(text):
        raise FlowvoError(f"{what} name {name!r} may hold only letters, digits, '.', '_' and '-', and must not "
                          "start with '.' or '-'")
    return text


def run_outputs(sequence: str, steps: bool = False) -> list[str]:
    """What ``flowvo run`` writes into its output folder for ``sequence`` (an already validated name);
    ``steps``: a windowed method's step records too."""
    return [f"{sequence}.txt", f"{sequence}.tum", "timing.json", "run.json", f"eval_{sequence}"] + \
        ([steps_csv_name(sequence)] if steps else [])


def steps_csv_name(sequence: str) -> str:
    """The file of a windowed run's step records (:mod:`flowvo.drive.steps_csv`)."""
    return f"{sequence}_steps.csv"


def is_inside(path: str | Path, folder: str | Path) -> bool:
    """True when ``path`` is ``folder`` or lies below it, after resolving links and ``..``."""
    inner, outer = Path(path).resolve(), Path(folder).resolve()
    return inner == outer or outer in inner.parents


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path)
    else:
        path.unlink()


def check_path_text(path: str | Path, what: str) -> Path:
    """``path`` as a Path, refused when empty (``--out ''`` would mean the current folder) or when its
    name cannot be handed to OpenCV or written in a UTF-8 file (bytes that are not UTF-8: OpenCV crashes
    the process on them)."""
    text = os.fspath(path)
    if not text:
        raise FlowvoError(f"{what} is empty; give a folder or file name")
    try:
        text.encode("utf-8")
    except UnicodeEncodeError:
        raise FlowvoError(f"{what} holds bytes that are not UTF-8 text; rename it", ascii(text)) from None
    return Path(text)


def prepare_output_dir(out: str | Path, produces: Sequence[str], force: bool = False,
                       dataset: str | Path | None = None, what: str = "--out") -> Path:
    """Check and create the output folder ``out`` for a command that writes the entries ``produces``.

    ``dataset``: the dataset root the command reads; ``out`` must not be it or lie inside it.
    Without ``force``, any of ``produces`` existing is an error; with it they stay until the new ones
    replace them (see the module docstring). Raises :class:`FlowvoError` naming ``out`` and the reason.
    """
    path = check_path_text(out, what)
    if path.exists() and not path.is_dir():
        raise FlowvoError(f"{what} is a file, expected a folder", path)
    if dataset is not None and Path(dataset).is_dir() and is_inside(path, dataset):
        raise FlowvoError(f"{what} is inside the dataset {dataset}; results must not be written into the data "
                          "(they could be read back as ground truth): choose another folder", path)
    existing = [name for name in produces if (path / name).exists() or (path / name).is_symlink()]
    if existing and not force:
        shown = ", ".join(existing[:4]) + (", ..." if len(existing) > 4 else "")
        raise FlowvoError(f"holds an earlier result ({shown}); pass --force to replace it, or choose another "
                          f"{what}", path)
    try:
        path.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=path):
            pass
    except OSError as error:
        raise FlowvoError(f"{what} cannot be written: {error.strerror or error}", path) from None
    return path


def prepare_output_file(target: str | Path, force: bool = False, what: str = "--out",
                        dataset: str | Path | None = None) -> Path:
    """Check a single output file: not a folder, not in ``dataset``, its folder writable, no earlier file
    unless ``force`` (which replaces it atomically once the new one is written)."""
    path = check_path_text(target, what)
    if path.is_dir():
        raise FlowvoError(f"{what} is a folder, expected a file name", path)
    if dataset is not None and Path(dataset).is_dir() and is_inside(path, dataset):
        raise FlowvoError(f"{what} is inside the dataset {dataset}; results must not be written into the data "
                          "(they could overwrite its files): choose another place", path)
    if (path.exists() or path.is_symlink()) and not force:
        raise FlowvoError(f"holds an earlier result; pass --force to replace it, or choose another {what}", path)
    prepare_output_dir(path.parent, [], what=f"the folder of {what}")
    return path


def remove_outputs(out: str | Path, names: Sequence[str]) -> None:
    """Remove the entries ``names`` of ``out`` that exist (files, links or folders)."""
    for name in names:
        entry = Path(out) / name
        if entry.exists() or entry.is_symlink():
            _remove(entry)


def _swap_in(new: Path, target: Path) -> None:
    """Move ``new`` to ``target``: a file by one rename over the old one; a folder by moving the old one
    aside first and removing it after."""
    if new.is_dir() and (target.exists() or target.is_symlink()):
        old = Path(tempfile.mkdtemp(prefix=f".{target.name}.", suffix=".old", dir=target.parent))
        os.replace(target, old / target.name)
        os.replace(new, target)
        shutil.rmtree(old)
    else:
        os.replace(new, target)


@contextmanager
def staged_outputs(out: str | Path, produces: Sequence[str]) -> Iterator[Path]:
    """Yield a hidden staging folder in ``out`` to write a whole result into (entries named as in
    ``produces``). When the block succeeds each entry replaces its namesake in ``out`` and the entries of
    ``produces`` the new result lacks are removed; when it fails (disk full, Ctrl-C) the staging folder is
    removed and ``out`` is exactly as before."""
    out = Path(out)
    staging = Path(tempfile.mkdtemp(prefix=".flowvo.", suffix=".new", dir=out))
    try:
        yield staging
        written = [name for name in produces if (staging / name).exists()]
        for name in written:
            _swap_in(staging / name, out / name)
        remove_outputs(out, [name for name in produces if name not in written])
    except OSError as error:  # named as the user knows it: OUT/NAME, not the staging folder
        if error.filename is None or not Path(error.filename).is_relative_to(staging):
            raise
        raise type(error)(error.errno, error.strerror, str(out / Path(error.filename).relative_to(staging))) \
            from None
    finally:
        shutil.rmtree(staging, ignore_errors=True)


def _lock_holder(handle: IO[str]) -> str:
    handle.seek(0)
    pid = handle.read().strip()
    return f"process {pid}" if pid.isdigit() else "another process"


def _is_current(path: Path, handle: IO[str]) -> bool:
    """True when ``path`` still names the file ``handle`` has open (a finished writer removes it)."""
    try:
        return os.stat(path).st_ino == os.fstat(handle.fileno()).st_ino
    except FileNotFoundError:
        return False


@contextmanager
def output_lock(out: str | Path) -> Iterator[None]:
    """Hold ``out/.flowvo.lock`` (an exclusive ``flock`` on a file holding this PID) for the block: a
    second command writing the same folder meanwhile is refused with one line naming the folder and the
    holder's PID. The file is removed when the block ends; the lock dies with the process, so a killed
    run never leaves the folder locked (its file then stays, unlocked)."""
    path = Path(out) / LOCK_NAME
    while True:
        handle = open(path, "a+", encoding="utf-8")  # noqa: SIM115 (held open for the whole block)
        try:
            fcntl.flock(handle.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = _lock_holder(handle)
            handle.close()
            raise FlowvoError(f"is being written by {holder} (lock {LOCK_NAME}); wait for it to finish or "
                              "choose another folder", out) from None
        if _is_current(path, handle):
            break
        handle.close()  # locked a file its holder removed meanwhile: lock the new one
    try:
        handle.truncate(0)
        handle.write(str(os.getpid()))
        handle.flush()
        yield
    finally:
        path.unlink(missing_ok=True)
        handle.close()


@contextmanager
def claim_output_dir(out: str | Path, produces: Sequence[str], force: bool = False,
                     dataset: str | Path | None = None) -> Iterator[Path]:
    """:func:`prepare_output_dir`, then hold :func:`output_lock` for the block, checking again under the
    lock (a run into the same folder that finished in between is not overwritten without ``force``)."""
    path = prepare_output_dir(out, produces, force, dataset)
    with output_lock(path):
        yield prepare_output_dir(path, produces, force, dataset)
