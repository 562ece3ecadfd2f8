"""Marker detection, clicking and pixel-to-3D reconstruction (triangulation and the paper's MLP) for dempath."""
