"""Runs: a scene filled, its markers picked, the tool driven and recorded, on either backend.

`backend.py` holds the one call shape (`Backend.run(scene, options) -> SimResult`), `physics.py`
the scene -> engine-parameter build both backends use, `bed/` the bed's preparation (pour, settle,
packing cache and file, tool placement; one entry point, `bed.fill_bed`), `markers.py` the marker
and candidate choice, `results.py` the `SimResult` record and `native.py` the run on dempath's
engine; `identity.py` what a run is (scene and physics keys, seed, tool speed), written into
every run's metadata by both backends. The LIGGGHTS backend is `dempath_sim.liggghts`.
"""

from __future__ import annotations

from dempath_sim.runs.backend import Backend, Frame, Progress, RunOptions
from dempath_sim.runs.bed import FillReport, fill_bed, packing_key
from dempath_sim.runs.identity import RunIdentity, run_id, run_identity
from dempath_sim.runs.markers import (
    ROLE_BED,
    ROLE_CANDIDATE,
    ROLE_MARKER,
    MarkerSelection,
    select_markers,
)
from dempath_sim.runs.native import NativeBackend, Variant, run_batch, run_scene
from dempath_sim.runs.physics import PARTICLES, TOOL, WALLS, bin_walls, build_params
from dempath_sim.runs.results import SimResult

__all__ = ['PARTICLES', 'ROLE_BED', 'ROLE_CANDIDATE', 'ROLE_MARKER', 'TOOL', 'WALLS', 'Backend',
           'FillReport', 'Frame', 'MarkerSelection', 'NativeBackend', 'Progress', 'RunIdentity',
           'RunOptions', 'SimResult', 'Variant', 'bin_walls', 'build_params', 'fill_bed',
           'packing_key', 'run_batch', 'run_id', 'run_identity', 'run_scene', 'select_markers']
