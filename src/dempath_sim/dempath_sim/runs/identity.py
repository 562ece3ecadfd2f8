"""What a run is: its scene set-up, physics, packing seed and tool speed, in every run's metadata.

Both backends (the native engine and LIGGGHTS) write these fields into ``SimResult.meta`` (and
so into ``dempath simulate``'s ``summary.json`` and ``result.npz``); the comparison
(``dempath_compare.runinfo``) reads them instead of parsing file or run names:

- ``run_id``: ``<scene>-s<seed>-<hash of the whole scene>``, a readable label;
- ``scene``: the scene's name;
- ``scene_key``: a hash of the set-up (bin, layers, tool and its speed profile, markers, fill,
  output, numerics; the tool's STL and a packing file by their content, not their path), without
  name, seed, materials or effects: two runs with one scene key differ only in physics and seed;
- ``physics_key``: a hash of the resolved physics of the run and of its bed
  (``scene.physics_model()``, ``scene.bed_model()``): materials and every effect's values;
- ``seed``: the packing seed;
- ``tool_speed_m_s``: the scene's nominal steady tool speed (its speed profile) [m/s], what an
  experiment at that speed is paired with; ``tool_speed_scale``: the ``tool_speed`` effect's
  factor (part of the physics: a run with a scaled speed still models the nominal experiment),
  and ``tool_speed_driven_m_s`` the speed the tool was driven at.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from dempath_sim.scene.spec import SceneSpec

KEY_CHARS = 16  # hex characters of the scene and physics keys


def _digest(payload: object, chars: int) -> str:
    text = json.dumps(payload, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:chars]


def _file_digest(path: str | Path | None) -> str | None:
    """sha256 of a file the scene names (hex, 16 chars; 'missing' when it cannot be read), None
    for no file."""
    if path is None:
        return None
    try:
        return hashlib.sha256(Path(path).read_bytes()).hexdigest()[:KEY_CHARS]
    except OSError:
        return 'missing'


def run_id(scene: SceneSpec) -> str:
    """Label of one run: scene name, seed and a short hash of everything that changes the run.

    The hash covers the whole scene record (effects and the bed's effects, bin, layers,
    materials, tool and profile, markers, fill, output cadence, numerics such as the time step)
    and the bytes of the files it names (the tool's STL, a ``fill.packing``) in place of their
    paths, so that two runs with the same id are the same run; the scene's name (the id's
    prefix), description and path are left out.
    """
    record = scene.to_dict()
    for label in ('name', 'source', 'description'):
        record.pop(label, None)
    record['tool']['mesh'] = _file_digest(scene.tool.mesh)  # the bytes, not where they lie
    if scene.fill.packing is not None:
        record['fill']['packing'] = _file_digest(scene.fill.packing)
    text = json.dumps(record, sort_keys=True, default=str)
    return f'{scene.name}-s{scene.seed}-{hashlib.sha256(text.encode()).hexdigest()[:8]}'


def scene_key(scene: SceneSpec) -> str:
    """Hash of the scene's set-up without its name, seed, materials and effects."""
    setup = scene.to_dict()
    for key in ('name', 'description', 'seed', 'source', 'materials', 'effects', 'bed_effects'):
        setup.pop(key, None)
    setup['tool']['mesh'] = _file_digest(scene.tool.mesh)
    setup['fill']['packing'] = _file_digest(scene.fill.packing)
    return _digest(setup, KEY_CHARS)


def physics_key(scene: SceneSpec) -> str:
    """Hash of the resolved physics of the run and of the bed it is poured with."""
    return _digest({'run': asdict(scene.physics_model()), 'bed': asdict(scene.bed_model())},
                   KEY_CHARS)


@dataclass(frozen=True)
class RunIdentity:
    """What a run is (module docstring): the fields every backend writes into its metadata."""

    run_id: str
    scene: str
    scene_key: str
    physics_key: str
    seed: int
    tool_speed_m_s: float
    tool_speed_scale: float
    tool_speed_driven_m_s: float

    def as_meta(self) -> dict[str, Any]:
        """The fields as a plain dict (for ``SimResult.meta``)."""
        return asdict(self)


def run_identity(scene: SceneSpec) -> RunIdentity:
    """The identity of a run of ``scene`` (its effects, seed and speed profile as set)."""
    speed = float(scene.tool.profile.speed_m_s)
    scale = float(scene.physics_model().speed_scale)
    return RunIdentity(run_id=run_id(scene), scene=scene.name, scene_key=scene_key(scene),
                       physics_key=physics_key(scene), seed=int(scene.seed),
                       tool_speed_m_s=speed, tool_speed_scale=scale,
                       tool_speed_driven_m_s=speed * scale)
