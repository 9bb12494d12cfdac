"""flowvo: monocular visual odometry from dense optical flow, with metric scale from the road."""

__version__ = "0.1.0"
