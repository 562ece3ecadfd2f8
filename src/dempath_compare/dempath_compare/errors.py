"""Errors of dempath_compare. Messages name the input and what is wrong with it."""

from __future__ import annotations

from dempath.errors import DempathError


class CompareError(DempathError):  # type: ignore[misc]
    """Base class of the trajectory-comparison errors."""


class InputError(CompareError):
    """A trajectory source cannot be used at all (missing, empty folder, unreadable, bad columns).

    Problems of single trajectories (NaN, too short, no start of motion...) are not errors:
    they are reported per trajectory and the rest is still scored.
    """


class ConfigError(CompareError, ValueError):
    """A comparison setting is out of range (the message names the field and its value)."""
