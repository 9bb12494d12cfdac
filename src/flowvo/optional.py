"""Optional dependencies: imported when first needed, with a one-line error naming what installs them."""

from __future__ import annotations

import importlib
from types import ModuleType

from flowvo.errors import FlowvoError


def import_optional(module: str, purpose: str, extra: str) -> ModuleType:
    """Import ``module`` or raise a FlowvoError saying ``purpose`` needs it and ``pip install flowvo[extra]``."""
    try:
        return importlib.import_module(module)
    except ImportError:
        raise FlowvoError(f"{purpose} needs the {module} package: pip install 'flowvo[{extra}]' "
                          f"(or pip install {module})") from None
