"""Pixel-to-3D reconstruction for dempath: triangulation, the paper's MLP and better methods."""
