"""Start a dempath system: the demo and the node graphs it runs (the ROS ``*_bringup`` package)."""
