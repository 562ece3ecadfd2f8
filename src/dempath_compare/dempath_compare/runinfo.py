"""What a trajectory's experiment or run is: tool speed, run id and packing seed.

The loaders fill these fields of :class:`~dempath_compare.records.Track`; the scoring pairs
experiments and model runs by the speed field, never by parsing labels. Where they come from:

- a folder written by ``dempath simulate`` (``summary.json`` beside the CSVs): the run id and
  seed of its metadata, the speed from the metadata's ``tool_speed_m_s`` when it has one;
- otherwise, and for the speed until run metadata carry it, the name convention as a fallback:
  a tool speed named in the experiment / run / scene name (``experiment_1ms``, ``model_1p5ms``,
  ``reduced_1ms-s7-...`` -> 1.0 / 1.5 / 1.0 m/s), the seed in a dempath run id
  (``<scene>-s<seed>-<hash>``), the run id = the group name (file stem, bag run id).

NaN speed and seed -1 mean unknown; unknown speeds pair with every speed.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from typing import Any, NamedTuple

SPEED_IN_NAME = re.compile(r'(\d+(?:[._p]\d+)?)\s*_?m_?(?:/|p|per)?_?s(?![a-z])')
SEED_IN_RUN_ID = re.compile(r'-s(\d+)-[0-9a-f]{8}$')  # dempath_sim.runs.run_id's form


class RunInfo(NamedTuple):
    """Tool speed [m/s] (NaN: unknown), run id and packing seed (-1: unknown) of a group."""

    speed_m_s: float
    run_id: str
    seed: int


def speed_from_name(name: str) -> float:
    """Tool speed [m/s] named in ``name`` ('experiment_1p5ms' -> 1.5), NaN when none."""
    found = SPEED_IN_NAME.search(name.lower())
    return float(re.sub(r'[_p]', '.', found.group(1))) if found else math.nan


def speed_text(speed_m_s: float, fallback: str) -> str:
    """'1.5 m/s' for a known speed, else ``fallback`` (the group name)."""
    return f'{speed_m_s:g} m/s' if math.isfinite(speed_m_s) else fallback


def run_info(group: str, meta: Mapping[str, Any] | None = None) -> RunInfo:
    """The fields of a group from run metadata when given, else from the name convention."""
    meta = meta or {}
    run_id = str(meta.get('run_id') or group)
    speed = meta.get('tool_speed_m_s')
    if speed is None:
        speed = speed_from_name(str(meta.get('scene') or run_id))
    seed = meta.get('seed')
    if seed is None:
        found = SEED_IN_RUN_ID.search(run_id)
        seed = int(found.group(1)) if found else -1
    return RunInfo(float(speed), run_id, int(seed))
