"""Two-camera ChArUco calibration for dempath: synthetic rig, intrinsics, stereo extrinsics, world frame."""
