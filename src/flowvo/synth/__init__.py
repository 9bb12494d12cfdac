"""Synthetic driving sequences in the KITTI odometry layout, with exact ground-truth poses and flow."""
