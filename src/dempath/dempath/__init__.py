"""Shared ROS plumbing of dempath: bag I/O, player and recorder, executor helpers, the command."""
