"""Trajectory comparison of measured markers and model particles.

Start detection, DTW, nearest-point distances, MAE, RMSE, nRMSE, ranking (Kuře & Kuřetová 2025).
"""
