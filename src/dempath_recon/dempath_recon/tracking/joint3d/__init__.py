"""The joint two-camera 3D tracker (``StereoTrackConfig.engine = 'joint'``).

Beside the per-camera 2D tracker of :mod:`~dempath_recon.tracking.stereo` (which numbers each
camera's tracks and checks the pairs afterwards), this engine decides identities once per pair
of frames, in 3D and for both cameras together: every cross-camera pair of detections within an
epipolar gate is a candidate 3D point (``candidates``), each marker's 3D state is predicted to
the frame's stamps with a motion model that knows markers ride on sand (``motion``), and one
exact assignment (``assign``) gives each marker a pair, one camera's ray or nothing, each
detection used once, the epipolar residual inside the cost. A marker whose best and next-best
choice are close is left unnumbered. The markers are numbered at the start by fitting the known
grid to the first frames' 3D candidates (``grid_fit``), refusing while a fit shifted by one
pitch scores nearly as well. ``engine`` runs it frame by frame behind the same
``update``/``release``/``flush`` surface as the 2D tracker.
"""
