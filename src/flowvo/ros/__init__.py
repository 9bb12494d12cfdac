"""ROS interop: sensor_msgs images and CameraInfo in, nav_msgs/Odometry, TF and Path out.

Needs the optional ``ros`` extra (rosbags); modules import it lazily, inside functions, so the core install
never does.
"""
