"""Readers and writers for the KITTI odometry layout."""
