"""What a trajectory's experiment or run is: tool speed, run id, seed, scene and physics keys.

The loaders fill these fields of :class:`~dempath_compare.records.Track`; the scoring pairs
experiments and model runs on them (equal tool speeds, equal scene keys, where both sides know
them), never by parsing labels. Where they come from:

- run metadata: the ``summary.json`` a ``dempath simulate`` folder holds beside its CSVs (both
  backends write ``run_id``, ``seed``, ``tool_speed_m_s``, ``scene_key`` and ``physics_key``:
  ``dempath_sim.runs.identity``);
- only on request (``CompareConfig.identity_from_names``, ``dempath compare
  --identity-from-names``), the name convention for what the metadata do not say: a tool speed
  named in the experiment / run / scene name (``experiment_1ms``, ``model_1p5ms``,
  ``reduced_1ms-s7-...`` -> 1.0 / 1.5 / 1.0 m/s, ``SPEED_IN_NAME``) and the seed in a dempath run
  id (``<scene>-s<seed>-<hash>``);
- the run id is the group name (file stem, bag run id) when nothing else is known.

NaN speed, seed -1 and an empty key mean unknown; an unknown field pairs with every value.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from typing import Any, NamedTuple

SPEED_IN_NAME = re.compile(r'(\d+(?:[._p]\d+)?)\s*_?m_?(?:/|p|per)?_?s(?![a-z])')
SEED_IN_RUN_ID = re.compile(r'-s(\d+)-[0-9a-f]{8}$')  # dempath_sim.runs.run_id's form


class RunInfo(NamedTuple):
    """Tool speed [m/s] (NaN: unknown), run id, packing seed (-1: unknown), scene and physics
    keys ('': unknown) of a group, in the order of the last fields of ``Track``."""

    speed_m_s: float
    run_id: str
    seed: int
    scene_key: str = ''
    physics_key: str = ''


def speed_from_name(name: str) -> float:
    """Tool speed [m/s] named in ``name`` ('experiment_1p5ms' -> 1.5), NaN when none."""
    found = SPEED_IN_NAME.search(name.lower())
    return float(re.sub(r'[_p]', '.', found.group(1))) if found else math.nan


def speed_text(speed_m_s: float, fallback: str) -> str:
    """'1.5 m/s' for a known speed, else ``fallback`` (the group name)."""
    return f'{speed_m_s:g} m/s' if math.isfinite(speed_m_s) else fallback


def run_info(group: str, meta: Mapping[str, Any] | None = None,
             from_names: bool = False) -> RunInfo:
    """The fields of a group from its run metadata; with ``from_names``, what the metadata do
    not say from the name convention (speed in the scene or run name, seed in a run id)."""
    meta = meta or {}
    run_id = str(meta.get('run_id') or group)
    speed = meta.get('tool_speed_m_s')
    if speed is None:
        speed = speed_from_name(str(meta.get('scene') or run_id)) if from_names else math.nan
    seed = meta.get('seed')
    if seed is None:
        found = SEED_IN_RUN_ID.search(run_id) if from_names else None
        seed = int(found.group(1)) if found else -1
    return RunInfo(float(speed), run_id, int(seed), str(meta.get('scene_key') or ''),
                   str(meta.get('physics_key') or ''))
