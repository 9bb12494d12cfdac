"""ROS interop: sensor_msgs images and CameraInfo in, nav_msgs/Odometry, TF and Path out.

Needs the optional ``ros`` extra (rosbags, mcap); every module imports those lazily, so the core install
never does.
"""
