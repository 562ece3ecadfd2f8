"""A re-settled bed shared between runs whose re-settle is the same computation (issue 30).

Every pass re-settles its packing against the standing tool with the run's own physics
(``tool.settle_s``, ``runs.native.resettle``) before the tool moves. Two runs whose re-settle
reads the same packing, tool, physics and numerics compute the very same re-settled bed: runs
that differ only in what shapes the drive (the tool's speed scale, speed profile and travel) or
the output. :func:`settled_key` hashes exactly what the re-settle reads, so such runs share one
key; the first writes the engine's checkpoint of the re-settled bed (its list, springs, forces
and the tool's force) into the packing cache (``<cache>/settled/<key>.npz``) and the others
resume from it: their pass is the same to the bit as with their own re-settle (the test
``test_shared_settle``). A run with other contact physics (friction, stiffness, cohesion...)
has another key and re-settles itself: starting it from another physics' bed would change what
it computes.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import zipfile
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dempath_sim.runs.bed import default_cache_dir, packing_key
from dempath_sim.scene.spec import SceneSpec

logger = logging.getLogger(__name__)

SETTLE_VERSION = 1  # bump when the re-settle or what a checkpoint holds changes
SETTLED_DIR = 'settled'  # folder of the packing cache holding the re-settled beds
# What only shapes the drive, never the re-settle (the tool stands at its start meanwhile).
DRIVE_ONLY_TOOL = ('profile', 'travel_m')
DRIVE_ONLY_EFFECTS = ('tool_speed',)
RUN_FIELDS = ('tool_force', 'tool_torque')  # engine attributes a checkpoint does not keep


def settled_key(scene: SceneSpec) -> str:
    """Hash (20 hex) of what the re-settle of a pass of ``scene`` reads: the packing (by its
    key), the tool (mesh bytes, scale, depth, start, placement, re-settle time), the run's
    physics and numerics; not the tool's speed, profile or travel, nor the output."""
    data: dict[str, Any] = scene.to_dict()
    for key in ('name', 'description', 'source', 'output', 'markers'):
        data.pop(key, None)
    for key in DRIVE_ONLY_TOOL:
        data['tool'].pop(key, None)
    for key in DRIVE_ONLY_EFFECTS:
        data['effects'].pop(key, None)
    data['tool']['mesh'] = hashlib.sha256(Path(scene.tool.mesh).read_bytes()).hexdigest()
    data['sim'] = asdict(scene.sim)
    payload = {'version': SETTLE_VERSION, 'packing': packing_key(scene, scene.bed_model()),
               'scene': data}
    text = json.dumps(payload, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:20]


def settled_file(scene: SceneSpec, cache_dir: Path | None = None) -> Path:
    """Where the re-settled bed of ``scene``'s pass is kept (it may not exist yet)."""
    return (cache_dir or default_cache_dir()) / SETTLED_DIR / f'{settled_key(scene)}.npz'


def save_settled(path: Path, checkpoint: dict[str, NDArray[Any]], run: dict[str, Any]) -> None:
    """Write an engine checkpoint and the run's fields (``RUN_FIELDS``) atomically (a killed
    run leaves no half-written entry; concurrent writers each use their own temporary file)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f'.{path.stem}.{os.getpid()}.tmp.npz')
    arrays = {**checkpoint, **{f'run.{k}': np.asarray(run[k]) for k in RUN_FIELDS}}
    np.savez(tmp, **arrays)  # type: ignore[arg-type]
    tmp.replace(path)


_DAMAGED = (zipfile.BadZipFile, EOFError, KeyError, ValueError, OSError)


def load_settled(path: Path) -> dict[str, NDArray[Any]] | None:
    """The arrays of a kept re-settled bed, or None when there is none or it is damaged (then
    named in a warning and removed: the run re-settles itself)."""
    if not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=False) as data:
            out = {k: np.array(data[k]) for k in data.files}
        missing = [k for k in RUN_FIELDS if f'run.{k}' not in out]
        if missing:
            raise KeyError(f'run.{missing[0]}')
    except _DAMAGED as err:
        logger.warning('settle: kept re-settled bed %s is damaged (%s: %s); re-settling',
                       path, type(err).__name__, err)
        path.unlink(missing_ok=True)
        return None
    return out


__all__ = ['SETTLED_DIR', 'SETTLE_VERSION', 'load_settled', 'save_settled', 'settled_file',
           'settled_key']
