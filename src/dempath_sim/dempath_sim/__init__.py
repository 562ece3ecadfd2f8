"""The DEM engine of dempath: kinematic tillage tool, pluggable effects, LIGGGHTS backend."""
