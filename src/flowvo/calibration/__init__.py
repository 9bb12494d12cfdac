"""Camera calibration: reading and writing calibration files, and calibrating from a checkerboard."""
