"""Errors of dempath_sim (engine, scenes, runs). Messages name the input and what is wrong."""

from __future__ import annotations

from dempath.errors import DempathError


class SimulationError(DempathError):
    """The simulation is unstable or cannot start (time step, overlaps, energy blow-up, inputs)."""


class GeometryError(DempathError):
    """A geometry input (STL file, mesh, wall) is malformed."""


class RunStoppedError(SimulationError):
    """The run was asked to stop (``RunOptions.stop``) before it had any output."""


class SceneError(DempathError):
    """A scene file is missing, unreadable, or has a wrong key, unit or value."""
