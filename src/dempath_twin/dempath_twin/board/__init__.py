"""The twin's calibration: the ChArUco board rendered into the twin rig's cameras.

``renderer`` (a planar board into a distorted camera, geometrically exact), ``recording``
(board poses, rendered views, truth, synthetic point sets), ``bag`` (the calibration bag or
videos) and ``shipped_mlp`` (rebuild the MLP dempath_recon ships from the twin's point set).
"""
