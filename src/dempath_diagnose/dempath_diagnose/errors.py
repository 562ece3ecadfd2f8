"""Errors of dempath_diagnose. Messages name the input and what is wrong with it."""

from __future__ import annotations

from dempath.errors import DempathError


class DiagnosisError(DempathError):  # type: ignore[misc]
    """Base class of the diagnosis errors."""


class MeasurementError(DiagnosisError):
    """A measured input (trajectories, force) cannot be used at all."""


class LibraryError(DiagnosisError):
    """The signature library cannot be built or read."""


class ClusterError(DiagnosisError):
    """The Dask scheduler cannot be reached or a sweep cannot run."""
