"""Streaming side of the diagnosis: measured frames and force samples in, a Measurement out.

The node feeds one frame at a time (:meth:`LiveDiagnoser.add_markers`, :meth:`add_force`) and
calls :meth:`LiveDiagnoser.finish` when the measured pass ends; :func:`measurement_from_frames`
is the batch form (same code), so live and recorded passes are diagnosed alike.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from dempath_diagnose.decision.diagnosis import CaseGeometry, Diagnosis, diagnose
from dempath_diagnose.decision.emulator import Allowance
from dempath_diagnose.decision.measure import COMMON_STEP_S, track_problem
from dempath_diagnose.errors import MeasurementError
from dempath_diagnose.library.store import Library
from dempath_diagnose.records import F64, Measurement


def measurement_from_frames(frames: Sequence[tuple[float, NDArray[np.int64], F64]],
                            ) -> Measurement:
    """A Measurement from (t [s], marker ids (n,), positions (n, 3) [m]) frames.

    Times are taken relative to the first frame (t = 0 when the tool starts to move).
    """
    if not frames:
        raise MeasurementError('measured markers: no frame received')
    t0 = frames[0][0]
    markers = sorted({int(m) for _, ids, _ in frames for m in ids})
    col = {m: j for j, m in enumerate(markers)}
    times = np.array([t - t0 for t, _, _ in frames])
    raw = np.full((len(frames), len(markers), 3), np.nan)
    for i, (_, ids, xyz) in enumerate(frames):
        for m, p in zip(ids, xyz, strict=True):
            raw[i, col[int(m)]] = p
    problems: dict[int, str] = {}
    keep = []
    for j, m in enumerate(markers):
        problem = track_problem(times, raw[:, j])
        if problem:
            problems[m] = problem
        else:
            keep.append(j)
    if not keep:
        raise MeasurementError('measured markers: no usable marker trajectory')
    grid = np.arange(0.0, times[-1] + 1e-9, COMMON_STEP_S)
    positions = np.full((len(grid), len(keep), 3), np.nan)
    for jj, j in enumerate(keep):
        ok = np.isfinite(raw[:, j]).all(1)
        inside = (grid >= times[ok].min()) & (grid <= times[ok].max())
        for a in range(3):
            positions[inside, jj, a] = np.interp(grid[inside], times[ok], raw[ok, j, a])
    return Measurement(np.array([markers[j] for j in keep], np.int64), grid, positions,
                       problems=problems)


@dataclass
class LiveDiagnoser:
    """Accumulates one measured pass and diagnoses it against a built library.

    Attributes:
        library: The scene's signature library.
        geometry: Tool axis, axis half width, cube size.
        allowance: Noise and discrepancy allowance.
        n_windows: Time windows of the statistics.
        held_out: Marker numbers left out of the diagnosis and scored apart (the check that
            the diagnosis did not only fit the markers it saw; as ``dempath diagnose
            --held-out``).
    """

    library: Library
    geometry: CaseGeometry
    allowance: Allowance = field(default_factory=Allowance)
    n_windows: int = 4
    held_out: tuple[int, ...] = ()
    frames: list[tuple[float, NDArray[np.int64], F64]] = field(default_factory=list)
    forces: list[tuple[float, F64]] = field(default_factory=list)

    def add_markers(self, t: float, ids: NDArray[np.int64], xyz: F64) -> None:
        """One measured frame (t [s], ids (n,), positions (n, 3) [m])."""
        self.frames.append((t, ids, xyz))

    def add_force(self, t: float, force: F64) -> None:
        """One force sample (t [s], force of the particles on the tool (3,) [N])."""
        if all(math.isfinite(v) for v in force):
            self.forces.append((t, np.asarray(force, np.float64)))

    def finish(self) -> Diagnosis:
        """Diagnose the pass received so far and start a new one."""
        frames, forces = self.frames, self.forces
        self.frames, self.forces = [], []
        meas = measurement_from_frames(frames)
        held = None
        if self.held_out:
            meas, held = meas.split(self.held_out)
            missing = sorted(set(self.held_out) - {int(m) for m in held.markers})
            if missing or len(meas.markers) < 2:
                raise MeasurementError(
                    f'held_out {",".join(map(str, self.held_out))}: '
                    + (f'marker(s) {missing} not received (or faulty)' if missing else
                       f'leaves {len(meas.markers)} marker(s) to diagnose'))
        if len(forces) >= 3:
            t0 = frames[0][0]
            meas = replace(meas, force_times=np.array([t - t0 for t, _ in forces]),
                           force=np.array([f for _, f in forces]))
        result = diagnose(meas, self.library, self.geometry, self.allowance, self.n_windows,
                          'force topic')
        result.held_out = held
        return result


def held_out_markers(text: str) -> tuple[int, ...]:
    """The marker numbers of the node's ``held_out`` parameter ('3,8,13'; '' for none).

    Raises:
        MeasurementError: Not distinct integers >= 1 separated by commas.
    """
    try:
        markers = tuple(int(v) for v in text.split(',') if v.strip())
    except ValueError as err:
        raise MeasurementError(f'held_out {text!r}: expected marker numbers separated by '
                               'commas, e.g. 3,8,13') from err
    if len(set(markers)) != len(markers) or any(m < 1 for m in markers):
        raise MeasurementError(f'held_out {text!r}: distinct marker numbers >= 1')
    return markers


def build_live(scene: str, library: Path, n_windows: int = 4, noise_m: float = 0.0015,
               discrepancy_m: float = 0.002, held_out: tuple[int, ...] = ()) -> LiveDiagnoser:
    """A LiveDiagnoser for ``scene`` on the built library in ``library``, the markers
    ``held_out`` scored apart.

    Raises:
        LibraryError: The library is missing or incomplete (build it with ``dempath diagnose``),
            or built for another scene or other physics.
    """
    from dempath_diagnose.library.simulator import load_scene, tool_geometry

    spec = load_scene(scene)
    tool_x, half_width, cube = tool_geometry(spec)
    allowance = Allowance(noise_m=noise_m, discrepancy_m=discrepancy_m)
    built = Library.load(library)
    built.check_scene(spec)
    return LiveDiagnoser(built, CaseGeometry(tool_x, half_width, cube), allowance, n_windows,
                         held_out)
