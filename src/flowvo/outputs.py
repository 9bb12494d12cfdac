"""Where results go: names that are names (not paths), and output folders checked before any work.

Rules every writing sub-command follows (through :func:`prepare_output_dir`):

- ``--out`` is a folder: an existing file there is refused, so is a folder that cannot be created or
  written (read-only, permission denied), before any long computation starts;
- results never go into the dataset (``--out`` at or below ``--data`` is refused), so a prediction can
  never be read back as ground truth or overwrite it;
- an earlier result is never overwritten silently: if any file the command would write exists, it is
  refused unless the user passes ``--force``, which first removes exactly those files (so no stale
  ``eval_NN/`` of an earlier run survives).

Imports neither torch nor OpenCV (``flowvo eval`` uses it).
"""

from __future__ import annotations

import re
import shutil
import tempfile
from collections.abc import Sequence
from pathlib import Path

from flowvo.errors import FlowvoError

_NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9._-]*$")


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


def run_outputs(sequence: str) -> list[str]:
    """What ``flowvo run`` writes into its output folder for ``sequence`` (an already validated name)."""
    return [f"{sequence}.txt", f"{sequence}.tum", "timing.json", "run.json", f"eval_{sequence}"]


def is_inside(path: str | Path, folder: str | Path) -> bool:
    """True when ``path`` is ``folder`` or lies below it, after resolving links and ``..``."""
    inner, outer = Path(path).resolve(), Path(folder).resolve()
    return inner == outer or outer in inner.parents


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path)
    else:
        path.unlink()


def prepare_output_dir(out: str | Path, produces: Sequence[str], force: bool = False,
                       dataset: str | Path | None = None, what: str = "--out") -> Path:
    """Check and create the output folder ``out`` for a command that writes the entries ``produces``.

    ``dataset``: the dataset root the command reads; ``out`` must not be it or lie inside it.
    With ``force``, the existing entries among ``produces`` are removed (only those); without it, any of
    them existing is an error. Raises :class:`FlowvoError` naming ``out`` and the reason.
    """
    path = Path(out)
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
        for name in existing:
            _remove(path / name)
    except OSError as error:
        raise FlowvoError(f"{what} cannot be written: {error.strerror or error}", path) from None
    return path


def prepare_output_file(target: str | Path, force: bool = False, what: str = "--out") -> Path:
    """Check a single output file: not a folder, its folder writable, no earlier file unless ``force``."""
    path = Path(target)
    if path.is_dir():
        raise FlowvoError(f"{what} is a folder, expected a file name", path)
    prepare_output_dir(path.parent, [path.name], force, what=f"the folder of {what}")
    return path
