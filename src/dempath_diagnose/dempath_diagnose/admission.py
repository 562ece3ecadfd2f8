"""The measured inputs of a diagnosis checked against the scene and each other before any work.

A wrong pairing of inputs gives a confident wrong answer, not an error, so each is refused with
one line naming what differs:

- the measured markers must start inside the scene's bin (after ``--origin``): a few outside are
  left out and named, most outside is refused;
- a force file's time base is checked as a marker file's is: no clock times, not
  milliseconds, no offset before the pass, and it must cover the measured pass.

The two other admissions sit in the rooms whose types they read: a library against its scene in
:mod:`dempath_diagnose.library.scene_identity`, a thin measurement in
:mod:`dempath_diagnose.decision.thin`.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from dempath_diagnose.errors import MeasurementError
from dempath_diagnose.records import F64, Measurement

if TYPE_CHECKING:
    from dempath_sim.scene import SceneSpec

MAX_CLOCK_START_S = 1e5  # a first time later than this is a clock time [s]
MAX_LEAD_S = 1.0  # a pass file may start this long before t = 0 [s]
MIN_COVER = 0.9  # the force must cover this fraction of the measured window
MS_RATIO = 50.0  # a force spanning this many times the markers' window is in milliseconds
BIN_SLACK_M = 0.005  # a marker start may lie this far outside the bin's walls [m]


def markers_in_bin(source: Path, meas: Measurement, scene: SceneSpec) -> Measurement:
    """``meas`` without the markers that start outside the scene's bin (after ``--origin``).

    A marker or two outside is a tracking fault of those markers: they are left out and named
    in the measurement's problems. Most markers outside is a wrong scene or ``--origin``.

    Raises:
        MeasurementError: More than half the markers start outside the bin (one line naming
            the first one and the bin).
    """
    from dataclasses import replace

    half = scene.bin.width_x_m / 2 + BIN_SLACK_M
    floor, top = -scene.bed_thickness_m, scene.bin.height_y_m - scene.bed_thickness_m
    p = meas.start
    inside = ((np.abs(p[:, 0]) <= half) & (p[:, 2] >= -BIN_SLACK_M)
              & (p[:, 2] <= scene.bin.length_z_m + BIN_SLACK_M)
              & (p[:, 1] >= floor - BIN_SLACK_M) & (p[:, 1] <= top + BIN_SLACK_M))
    if inside.all():
        return meas
    bin_text = (f'the bin of scene {scene.name!r} (X +-{scene.bin.width_x_m / 2:g}, Y '
                f'{floor:g}..{top:g}, Z 0..{scene.bin.length_z_m:g} m)')
    if 2 * int(inside.sum()) < len(inside):
        k = int(np.flatnonzero(~inside)[0])
        msg = (f'{source}: {int((~inside).sum())} of {len(inside)} markers start outside '
               f'{bin_text}, marker {int(meas.markers[k])} at ({p[k, 0]:.3f}, {p[k, 1]:.3f}, '
               f'{p[k, 2]:.3f}) m; check --scene and --origin')
        raise MeasurementError(msg)
    problems = {**meas.problems, **{int(m): f'starts outside {bin_text}'
                                    for m in meas.markers[~inside]}}
    return replace(meas, markers=meas.markers[inside], positions=meas.positions[:, inside],
                   problems=problems)


def check_force_time_base(source: Path, times: F64, meas_times: F64) -> None:
    """Refuse a force file whose time axis is not the pass time of the markers.

    Args:
        source: The force file.
        times: (n,) its times [s as given].
        meas_times: (k,) the measured markers' common times [s] (t = 0 at the pass start).

    Raises:
        MeasurementError: Clock times, milliseconds, an offset, or too short a coverage.
    """
    first, last = float(times[0]), float(times[-1])
    window = float(meas_times[-1]) if len(meas_times) else 0.0
    if first > MAX_CLOCK_START_S:
        msg = (f'{source}: t starts at {first:.0f} s, a clock time; t must be the pass time '
               '(t = 0 when the tool starts to move), as in the marker file')
        raise MeasurementError(msg)
    if window > 0 and last - first > MS_RATIO * window:
        msg = (f'{source}: t spans {last - first:.4g} "s" against the markers\' {window:.3g} s: '
               'the times look like milliseconds where seconds are expected')
        raise MeasurementError(msg)
    if first < -MAX_LEAD_S:
        msg = (f'{source}: t starts at {first:.3f} s, {-first:.3f} s before the pass start; t '
               'must be 0 when the tool starts to move (an offset?)')
        raise MeasurementError(msg)
    covered = min(last, window) - max(first, 0.0)
    if window > 0 and covered < MIN_COVER * window:
        msg = (f'{source}: the force covers t = {max(first, 0.0):.3f}..{last:.3f} s, '
               f'{max(covered, 0.0) / window:.0%} of the measured pass 0..{window:.3f} s (at '
               f'least {MIN_COVER:.0%} needed)')
        raise MeasurementError(msg)


def check_pass_times(source: Path, first: float, last: float) -> None:
    """Refuse marker times that hold no sample after the pass start or begin long before it.

    Raises:
        MeasurementError: One line with the times found.
    """
    if last <= 0.0 or first < -MAX_LEAD_S:
        msg = (f'{source}: t runs from {first:.3f} to {last:.3f} s; t must be the pass time '
               f'(t = 0 when the tool starts to move; at most {MAX_LEAD_S:g} s before it)')
        raise MeasurementError(msg)


__all__ = ['check_force_time_base', 'check_pass_times', 'markers_in_bin']
