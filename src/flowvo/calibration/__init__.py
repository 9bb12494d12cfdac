"""Camera calibration: reading and writing calibration files, and calibrating from a checkerboard or a
ChArUco board (``flowvo calibrate``)."""
