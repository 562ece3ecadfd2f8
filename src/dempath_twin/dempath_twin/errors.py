"""Errors of dempath_twin (all are ``dempath.errors.DempathError``: one line naming the input)."""

from __future__ import annotations

from dempath.errors import DempathError


class TwinError(DempathError):
    """A synthetic recording cannot be made (bad setting, encoding failure, failed run)."""
