"""Marker-level field twins: true marker tracks of a DEM run seen as pixels by the twin rig.

``markers`` (tracks, clicks and bag messages of the field twin), ``demo_bag`` (the demo's
field twin: a run with a hidden setting, as a bag) and ``two_cams`` (``bags/demo_two_cams``).
No images of the bed: those are ``dempath_twin.render``'s.
"""
