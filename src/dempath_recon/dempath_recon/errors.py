"""Errors of dempath_recon. Every message names the input and what is wrong with it."""

from __future__ import annotations

from dempath.errors import DempathError


class ReconstructionError(DempathError):
    """Pixels cannot be turned into 3D points with the given method and inputs."""


class ModelFileError(ReconstructionError):
    """A reconstruction model or calibration file is missing, unreadable or malformed."""


class NotFittedError(ReconstructionError):
    """``predict`` was called on a reconstructor before ``fit`` or ``load``."""


class PixelInputError(ReconstructionError):
    """Pixel input of the wrong shape or type (rejected points are reported, not raised)."""


class ClickError(ReconstructionError):
    """A click file, a frame source or a request of the clicker is invalid (names which, why)."""
