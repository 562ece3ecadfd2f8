"""Pixel-to-3D reconstruction methods behind one interface (``registry``).

Classical two-camera geometry (``triangulate``, ``resection``), the paper's network (``mlp``, with
``nets``, ``scalers`` and ``params``) and its shipped weights (``shipped``), triangulation plus a
learned correction (``residual``), pixel-noise propagation (``uncertainty``), and the side-by-side
evaluation against the paper's Table 5 (``evaluation``). Imports only ``dempath_recon.errors`` from
its own package.
"""
