"""Errors of the LIGGGHTS backend. Messages name the input (binary, deck, log) and the fault."""

from __future__ import annotations

from dempath.errors import DempathError, DumpError


class LiggghtsError(DempathError):
    """Base class of the LIGGGHTS backend errors."""


class LiggghtsNotFoundError(LiggghtsError):
    """The LIGGGHTS binary (or mpirun for a parallel run) is missing and cannot be installed."""


class LiggghtsRunError(LiggghtsError):
    """LIGGGHTS exited with an error; the message names the deck and the log file."""


class DeckError(LiggghtsError):
    """A scene cannot be written as a LIGGGHTS deck (unsupported effect or value)."""


__all__ = ['DeckError', 'DumpError', 'LiggghtsError', 'LiggghtsNotFoundError',
           'LiggghtsRunError']
