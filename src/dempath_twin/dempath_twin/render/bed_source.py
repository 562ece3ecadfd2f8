"""The simulated bed a field recording is rendered from: every particle at the frame times.

A recording needs the whole bed (centres and radii of every sphere) at the cameras' frame rate,
and the tool's position. ``dempath_sim`` records the bed every ``output.snapshot_interval_s``
(``SimResult.snapshot_*``) but not the radii of the bed particles; they come from the run's
settled packing, which ``fill_bed`` reads back from the packing cache (or pours again, with the
same seed, when the cache was cleared). This module is the only one of the renderer that
touches ``dempath_sim``.

A run folder written by :func:`run_for_recording` holds ``result.npz`` (the SimResult, bed
snapshots included), ``bed_radii.npz`` (``ids``, ``radii``) and ``summary.json``; a folder
written by ``dempath simulate`` works too when its snapshots are dense enough.
"""

from __future__ import annotations

import json
import logging
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dempath_twin.errors import TwinError

LOG = logging.getLogger(__name__)
FloatArray = NDArray[np.float64]
SNAPSHOTS_PER_FRAME = 2  # snapshots per camera frame: lets each camera render at its own instant


class BedSourceError(TwinError):
    """A run or scene cannot give the bed at the frame rate (names the input and the fault)."""


@dataclass(frozen=True)
class BedRecord:
    """The bed of one run at its snapshot times (scene frame: X lateral, Y up, Z travel).

    Attributes:
        times: (ns,) snapshot times since the tool started [s].
        positions: (ns, n, 3) float32 sphere centres [m]; NaN once a sphere left the domain.
        radii: (n,) sphere radii [m].
        ids: (n,) stable particle ids.
        marker_ids: (m,) marker numbers (the scene's grid numbering).
        marker_index: (m,) column of each marker particle in ``positions``.
        tool_times: (nt,) output times of the tool pose [s].
        tool_position: (nt, 3) tool reference point (tip) [m].
        tool_mesh: (k, 3, 3) triangles of the tool at its reference pose [m].
        meta: run id, scene, seed, effects.
    """

    times: FloatArray
    positions: NDArray[np.float32]
    radii: FloatArray
    ids: NDArray[np.int64]
    marker_ids: NDArray[np.int32]
    marker_index: NDArray[np.int64]
    tool_times: FloatArray
    tool_position: FloatArray
    tool_mesh: FloatArray
    meta: dict[str, Any]

    def at(self, t: float) -> NDArray[np.float32]:
        """(n, 3) float32 centres at time ``t`` [s], linear between the two snapshots around."""
        k = int(np.clip(np.searchsorted(self.times, t) - 1, 0, len(self.times) - 2))
        w = np.float32(np.clip((t - self.times[k]) / (self.times[k + 1] - self.times[k]), 0, 1))
        return np.asarray((1 - w) * self.positions[k] + w * self.positions[k + 1], np.float32)

    def tool_at(self, t: float) -> FloatArray:
        """(3,) tool reference point at ``t`` [m] (linear between output times)."""
        return np.array([np.interp(t, self.tool_times, self.tool_position[:, i])
                         for i in range(3)])


def _scene_for_recording(scene: Any, fps: float) -> Any:
    """``scene`` with output intervals that give ``SNAPSHOTS_PER_FRAME`` bed snapshots a frame."""
    period = 1.0 / fps / SNAPSHOTS_PER_FRAME
    output = replace(scene.output, interval_s=min(scene.output.interval_s, period),
                     snapshot_interval_s=period)
    return replace(scene, output=output)


def run_for_recording(scene: Any, out: Path, fps: float = 50.0,
                      cache_dir: Path | None = None) -> Path:
    """Run ``scene`` (a dempath_sim SceneSpec) with bed snapshots at twice ``fps``; write ``out``.

    Returns:
        The run folder (``result.npz``, ``bed_radii.npz``, ``summary.json``).
    """
    from dempath_sim.runs import RunOptions, run_scene

    scene = _scene_for_recording(scene, fps)
    result = run_scene(scene, RunOptions(cache_dir=cache_dir))
    out.mkdir(parents=True, exist_ok=True)
    result.save_npz(out / 'result.npz')
    ids, radii = _packing_radii(scene, cache_dir)
    np.savez_compressed(out / 'bed_radii.npz', ids=ids, radii=radii)
    (out / 'summary.json').write_text(json.dumps({**result.meta, 'scene_yaml': scene.source},
                                                 indent=1, default=str))
    return out


def _packing_radii(scene: Any, cache_dir: Path | None) -> tuple[NDArray[np.int64], FloatArray]:
    """Ids and radii of the run's settled packing (read from the packing cache).

    The bed is looked up with the physics it was poured with (``scene.bed_model()``, as the
    run does), not the run's: with a hidden effect switched on (cohesion) the run's physics
    names another packing key, which would pour a second, different bed.
    """
    from dempath_sim.runs import build_params, fill_bed

    model = scene.bed_model()
    state, _ = fill_bed(scene, model, build_params(scene, model), cache_dir)
    return state.ids.astype(np.int64), state.radii.astype(np.float64)


def load_bed(run_dir: Path, fps: float, scene: Any | None = None,
             cache_dir: Path | None = None) -> BedRecord:
    """Read a run folder as a BedRecord.

    Args:
        run_dir: folder with ``result.npz`` (and ``bed_radii.npz``, else ``scene`` is refilled
            from the packing cache to find the radii).
        fps: the recording's frame rate; the snapshots must be at least this dense.
        scene: the run's SceneSpec, needed only without ``bed_radii.npz`` and for the tool.
        cache_dir: packing cache directory.

    Raises:
        BedSourceError: missing files, no snapshots, or snapshots sparser than the frames.
    """
    from dempath_sim.runs import SimResult

    path = run_dir / 'result.npz'
    try:
        result = SimResult.load_npz(path)
    except (OSError, KeyError, ValueError) as err:
        msg = f'{str(path)!r}: not a dempath_sim result ({err})'
        raise BedSourceError(msg) from err
    times = result.snapshot_times
    if len(times) < 2:
        msg = f'{str(path)!r}: the run has {len(times)} bed snapshots; a recording needs them ' \
              f'every 1/{fps:g} s (run the scene with output.snapshot_interval_s)'
        raise BedSourceError(msg)
    step = float(np.median(np.diff(times)))
    if step > 1.0 / fps + 1e-9:
        msg = f'{str(path)!r}: bed snapshots every {step:g} s, sparser than the frames ' \
              f'(1/{fps:g} s); rerun with output.snapshot_interval_s <= {1 / fps:g}'
        raise BedSourceError(msg)
    ids, radii = _radii(run_dir, result, scene, cache_dir)
    bed_ids = result.snapshot_ids.astype(np.int64)
    order = np.argsort(ids)
    at = np.searchsorted(ids, bed_ids, sorter=order).clip(0, len(ids) - 1)
    if not np.all(ids[order[at]] == bed_ids):
        msg = f'{str(run_dir)!r}: bed radii do not cover every snapshot particle'
        raise BedSourceError(msg)
    marker_cols = np.flatnonzero(result.roles == 0)
    where = np.searchsorted(bed_ids, result.ids[marker_cols], sorter=np.argsort(bed_ids))
    marker_index = np.argsort(bed_ids)[where.clip(0, len(bed_ids) - 1)]
    return BedRecord(times, result.snapshot_positions, radii[order[at]], bed_ids,
                     result.marker_ids[marker_cols].astype(np.int32),
                     marker_index.astype(np.int64), result.times, result.tool_position,
                     _tool_mesh(scene, result.meta), dict(result.meta))


def _radii(run_dir: Path, result: Any, scene: Any | None,
           cache_dir: Path | None) -> tuple[NDArray[np.int64], FloatArray]:
    path = run_dir / 'bed_radii.npz'
    if path.is_file():
        with np.load(path) as data:
            return data['ids'].astype(np.int64), data['radii'].astype(np.float64)
    if scene is None:
        msg = f'{str(run_dir)!r}: no bed_radii.npz and no scene to read the packing from'
        raise BedSourceError(msg)
    return _packing_radii(scene, cache_dir)


def _tool_mesh(scene: Any | None, meta: dict[str, Any]) -> FloatArray:
    """(k, 3, 3) tool triangles at its reference pose [m] (the scene's mesh and scale)."""
    from dempath_sim.engine import TriangleMesh

    if scene is None:
        from dempath_sim.scene import resolve_scene

        scene = resolve_scene(str(meta['source']))
    mesh = TriangleMesh.from_stl(scene.tool.mesh, material=0, scale=scene.tool.scale)
    return np.asarray(mesh.triangles, np.float64)
