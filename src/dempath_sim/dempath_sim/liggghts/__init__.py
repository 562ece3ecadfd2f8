"""LIGGGHTS 3.8 backend: write an input deck from a dempath scene, run it, read the dumps back.

Modules: ``install`` (find / apt-install LIGGGHTS), ``runner`` (run a deck, one-line errors),
``commands`` (deck building blocks shared by scenes and validation cases), ``deck`` (scene ->
deck), ``backend`` (`LiggghtsBackend`, the
`dempath_sim.runs.Backend` on LIGGGHTS: scene -> SimResult). Dump and print files are read by
:mod:`dempath.dumpio` (on the ground, so that the comparison reads them too).
"""

from __future__ import annotations

from dempath_sim.liggghts.backend import FILLS, LiggghtsBackend
from dempath_sim.liggghts.errors import (
    DeckError,
    DumpError,
    LiggghtsError,
    LiggghtsNotFoundError,
    LiggghtsRunError,
)
from dempath_sim.liggghts.install import LiggghtsInstall, ensure_liggghts

__all__ = ['FILLS', 'DeckError', 'DumpError', 'LiggghtsBackend', 'LiggghtsError',
           'LiggghtsInstall', 'LiggghtsNotFoundError', 'LiggghtsRunError', 'ensure_liggghts']
