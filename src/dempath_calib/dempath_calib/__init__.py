"""Two-camera ChArUco calibration for dempath: twin rig, intrinsics, stereo, world frame."""
