"""ROS 2 nodes of dempath_diagnose (the only modules that import rclpy or dempath_msgs)."""
