"""Shared ROS plumbing of dempath (bag player, recorder, conversions, executor helpers) and the dempath command."""
