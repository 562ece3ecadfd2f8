"""Errors of the shared dempath plumbing. Messages name the input and what is wrong with it."""

from __future__ import annotations


class DempathError(Exception):
    """Base class of every error dempath raises on purpose; CLIs print it as one line."""


class BagError(DempathError):
    """A bag cannot be read or written (missing, truncated, corrupt, unknown type, bad topic)."""


class OutputError(DempathError):
    """An output location cannot be written."""


class DumpError(DempathError):
    """A DEM text dump or print file cannot be read (missing, truncated, wrong columns)."""
