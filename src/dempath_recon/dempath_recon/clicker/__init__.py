"""The paper's Image Clicker as a local web page, and click files as pixel-frame streams.

``clicks`` (the click store and its CSV files), ``frames`` (the images a session shows),
``server`` (the local web server and ``web/``, its page), ``cli`` (``dempath click``) and
``playback`` (a click file as per-camera pixel frames, for the clicker node).
"""
