"""Rendered field recordings: the whole simulated bed as the twin rig's cameras see it.

``bed_source`` (every particle at the frame times), ``splat`` (z-buffered spheres and
triangles, shadows), ``camera_frame`` (one camera's shaded, distorted colour frame),
``recording`` (calibration segment plus the pass), ``bag`` (the MCAP bag and
``dempath twin render``) and ``conditions`` (field conditions laid over a recording's frames
in image space: light, shutter, flicker, shake, dust, noise, colour cast).
"""
