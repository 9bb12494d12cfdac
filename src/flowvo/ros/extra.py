"""The optional ``ros`` extra: a clear error when rosbags or mcap is not installed."""

from __future__ import annotations

from importlib.util import find_spec

from flowvo.errors import FlowvoError

ROS_PACKAGES = ("rosbags", "mcap")


def require_ros_extra(what: str) -> None:
    """Raise a one-line FlowvoError unless rosbags and mcap are importable; ``what`` names the feature."""
    missing = [name for name in ROS_PACKAGES if find_spec(name) is None]
    if missing:
        raise FlowvoError(f"{what} needs the ros extra ({', '.join(missing)} not installed): "
                          "pip install 'flowvo[ros]'")
