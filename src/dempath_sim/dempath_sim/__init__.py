"""The DEM engine of dempath: kinematic tillage tool, pluggable effects, LIGGGHTS backend.

Sub-packages, bottom to top (each imports only those before it; docs/dem.md, Code layout):
``effects`` (the model registry), ``engine`` (the DEM engine, one file per contact law in
``engine/laws``), ``scene`` (scene files), ``runs`` (fill, markers, results and the one
``Backend`` protocol with the native run), ``liggghts`` (the LIGGGHTS backend), ``validation``
(physics cases and the cross-engine check); ``nodes`` holds the ROS 2 node.
"""
