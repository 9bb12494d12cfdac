"""flowvo: learned visual odometry from dense optical flow."""

__version__ = "0.1.0"
