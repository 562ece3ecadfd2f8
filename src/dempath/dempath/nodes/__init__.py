"""ROS 2 nodes: thin adapters around the core modules (only this subpackage imports rclpy)."""
