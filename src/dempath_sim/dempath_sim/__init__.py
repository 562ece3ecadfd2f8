"""Discrete element method engine of dempath with a kinematic tillage tool, pluggable effects and a LIGGGHTS backend."""
