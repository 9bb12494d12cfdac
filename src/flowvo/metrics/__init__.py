"""Pure trajectory metrics over NumPy arrays: the KITTI odometry metric, ATE and RPE."""
