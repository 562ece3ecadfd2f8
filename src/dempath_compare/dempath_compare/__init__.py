"""Trajectory comparison of measured markers and model particles (start detection, DTW, MAE, RMSE, nRMSE, ranking)."""
