"""Errors of dempath_calib. Every message names the input and what is wrong with it."""

from __future__ import annotations

from dempath.errors import DempathError


class CalibrationError(DempathError):
    """A calibration cannot be computed from the given input."""


class CalibrationFileError(CalibrationError):
    """A calibration, camera or point-set file is missing, unreadable or malformed."""


class NotEnoughViewsError(CalibrationError):
    """Too few usable board views (the message says how many more and where coverage lacks)."""


class DegenerateViewsError(CalibrationError):
    """The board views do not constrain the camera (e.g. all in one pose)."""


class InputSourceError(CalibrationError):
    """A bag, frame folder or video given as calibration input cannot be read."""
