"""The optional ``ros`` extra: a clear error when rosbags is not installed."""

from __future__ import annotations

from importlib.util import find_spec

from flowvo.errors import FlowvoError


def require_ros_extra(what: str) -> None:
    """Raise a one-line FlowvoError unless rosbags is importable; ``what`` names the feature that needs it."""
    if find_spec("rosbags") is None:
        raise FlowvoError(f"{what} needs the ros extra (rosbags is not installed): pip install 'flowvo[ros]'")
