"""Frame sources: where the images of a drive come from (KITTI folders, video files, ROS bags)."""
