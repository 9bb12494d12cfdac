"""Where flow caches live when no ``--cache`` is given: the user's cache folder, never inside the dataset.

Default root: ``$XDG_CACHE_HOME/flowvo/flow`` (``~/.cache/flowvo/flow`` when the variable is unset),
then one folder per dataset, named after it and keyed by a hash of its resolved path, so two datasets
with the same folder name never share flow, and a read-only dataset works:
``<root>/<dataset name>-<sha256(resolved path)[:12]>/<sequence>/<method>_s<scale>/``.
"""

from __future__ import annotations

import hashlib
import os
import re
from pathlib import Path


def user_cache_dir() -> Path:
    """flowvo's folder in the user's cache: ``$XDG_CACHE_HOME/flowvo`` or ``~/.cache/flowvo``."""
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "flowvo"


def default_cache_root(data_root: str | Path) -> Path:
    """The flow-cache root of the dataset at ``data_root`` (sequences go one level below it)."""
    resolved = Path(data_root).resolve()
    key = hashlib.sha256(str(resolved).encode()).hexdigest()[:12]
    name = re.sub(r"[^A-Za-z0-9._-]", "_", resolved.name) or "root"
    return user_cache_dir() / "flow" / f"{name}-{key}"
