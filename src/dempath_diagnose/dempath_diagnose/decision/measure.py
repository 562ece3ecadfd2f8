"""Reading and checking a measured pass: marker tracks (CSV or bag) and the tool force (CSV).

Tracks come through dempath_compare's loaders (CSV ``t,marker,x,y,z`` or a bag with
``dempath_msgs/MarkerPoints3D``). Faults of single markers (NaN samples, fewer than 3 points,
duplicated time stamps, no motion) are recorded per marker and that marker is left out; faults
of the whole input (no usable marker, values that look like millimetres, absolute clock times in
a CSV) raise :class:`~dempath_diagnose.errors.MeasurementError` with one line naming the input.

A CSV's ``t`` is the pass time (t = 0 when the tool starts to move). A bag's stamps are the
cameras' clock: t = 0 is the first ``STARTED`` RunEvent on ``/markers/pass_events`` (the pass
node's) or ``/tool/events`` when the bag has one, else the first marker sample (the recording
started with the pass); :attr:`Measurement.time_origin` says which.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from dempath.errors import DempathError
from dempath_diagnose.admission import check_pass_times
from dempath_diagnose.errors import MeasurementError
from dempath_diagnose.records import F64, Measurement

if TYPE_CHECKING:
    from dempath_compare.records import Track

MIN_POINTS = 3
MIN_MOTION_M = 1e-4  # a marker that never moves this far is 'no motion' [m]
MAX_SPAN_M = 5.0  # positions spreading further than this look like millimetres [m]
MAX_PASS_START_S = 1e5  # a CSV whose first time is later than this holds clock times [s]
STARTED = 0  # dempath_msgs/RunEvent.STARTED
COMMON_STEP_S = 0.005  # common time base of the measured markers [s]


def load_tracks(path: Path, origin: Sequence[float] = (0.0, 0.0, 0.0)) -> Measurement:
    """The measured markers of ``path`` on a common time base, in the scene frame.

    Args:
        path: CSV ``t,marker,x,y,z`` or a bag with MarkerPoints3D.
        origin: Where the measured frame's origin lies in the scene frame [m].

    Raises:
        MeasurementError: Unreadable, no usable marker, or millimetre-like values.
    """
    from dempath_compare.loaders import is_bag, load_source
    from dempath_compare.records import MEASURED

    try:
        tracks = load_source(path, MEASURED)
        origin_s, time_origin = (bag_time_origin(path, tracks) if is_bag(path)
                                 else (0.0, ''))
    except DempathError as err:
        raise MeasurementError(str(err)) from err
    first = min((float(np.nanmin(t.times)) for t in tracks if len(t.times)), default=0.0)
    if first - origin_s > MAX_PASS_START_S:
        msg = (f'{path}: t starts at {first:.0f} s, a clock time; t must be the pass time '
               '(t = 0 when the tool starts to move)')
        raise MeasurementError(msg)
    tracks = [t._replace(times=t.times - origin_s) for t in tracks]
    problems: dict[int, str] = {}
    good = []
    for track in tracks:
        problem = track_problem(track.times, track.positions)
        if problem:
            problems[int(track.ident)] = problem
        else:
            good.append(track)
    if not good:
        detail = '; '.join(f'marker {k}: {v}' for k, v in sorted(problems.items()))
        raise MeasurementError(f'{path}: no usable marker trajectory ({detail})')
    span = max(float(np.nanmax(np.ptp(t.positions[np.isfinite(t.positions).all(1)], axis=0)))
               for t in good)
    if span > MAX_SPAN_M:
        msg = (f'{path}: markers move over {span:.0f} m; the values look like millimetres where '
               'metres are expected')
        raise MeasurementError(msg)
    end = max(float(np.nanmax(t.times)) for t in good)  # the whole pass: a marker lost early
    # counts where it was measured (statistics.window_presence), it never cuts the others
    check_pass_times(path, min(float(np.nanmin(t.times)) for t in good), end)
    times = np.arange(0.0, end + 1e-9, COMMON_STEP_S, dtype=np.float64)
    positions = np.full((len(times), len(good), 3), np.nan)
    shift = np.asarray(origin, np.float64)
    for j, track in enumerate(good):
        ok = np.isfinite(track.positions).all(1) & np.isfinite(track.times)
        t, p = track.times[ok], track.positions[ok] + shift
        inside = (times >= t.min()) & (times <= t.max())
        for a in range(3):
            positions[inside, j, a] = np.interp(times[inside], t, p[:, a])
    markers = np.array([int(t.ident) for t in good], np.int64)
    return Measurement(markers, times, positions, problems=problems, time_origin=time_origin)


def bag_time_origin(path: Path, tracks: Sequence[Track]) -> tuple[float, str]:
    """The stamp [s] that is t = 0 of a bag's pass, and where it came from (one phrase)."""
    from dempath import topics
    from dempath.bagio import open_bag

    with open_bag(path) as bag:
        wanted = [t for t in (topics.PASS_EVENTS, topics.TOOL_EVENTS)
                  if t in bag.topics and bag.topics[t].msgtype == 'dempath_msgs/msg/RunEvent']
        for raw in bag.messages(wanted) if wanted else ():
            event = bag.deserialize(raw)
            if int(event.event) == STARTED:
                stamp = event.header.stamp
                return (float(stamp.sec) + 1e-9 * float(stamp.nanosec),
                        f't = 0 at the pass start on {raw.topic} ({event.run_id or "no id"})')
    first = min(float(np.nanmin(t.times)) for t in tracks if len(t.times))
    return first, 't = 0 at the first marker sample (the bag has no pass-start RunEvent)'


def track_problem(times: F64, positions: F64) -> str:
    """Why one marker's track cannot be used, or '' (NaN samples alone are dropped)."""
    ok = np.isfinite(times) & np.isfinite(positions).all(1)
    if ok.sum() < MIN_POINTS:
        return f'fewer than {MIN_POINTS} finite points ({int(ok.sum())})'
    t = times[ok]
    if len(np.unique(t)) < len(t):
        return 'duplicated time stamps'
    if np.any(np.diff(t) < 0):
        return 'time stamps not increasing'
    p = positions[ok]
    if float(np.max(np.linalg.norm(p - p[0], axis=1))) < MIN_MOTION_M:
        return 'no motion'
    return ''


def load_force(path: Path) -> tuple[F64, F64]:
    """Times (n,) [s] and force (n, 3) [N] of a CSV ``t,Fx,Fy,Fz``.

    The force is that of the particles on the tool, so the draft -Fz is positive while the tool
    cuts; a force whose draft is mostly negative is in the other sign convention.

    Raises:
        MeasurementError: Unreadable, missing columns, too short, or the wrong sign convention.
    """
    from dempath_compare.loaders import read_csv_columns

    try:
        cols = read_csv_columns(Path(path))
    except DempathError as err:
        raise MeasurementError(str(err)) from err
    missing = [c for c in ('t', 'fx', 'fy', 'fz') if c not in cols]
    if missing:
        raise MeasurementError(f'{path}: missing column(s) {missing}; expected t,Fx,Fy,Fz')
    force = np.column_stack([cols['fx'], cols['fy'], cols['fz']])
    ok = np.isfinite(cols['t']) & np.isfinite(force).all(1)
    if ok.sum() < MIN_POINTS:
        raise MeasurementError(f'{path}: fewer than {MIN_POINTS} finite force samples')
    t, force = cols['t'][ok], force[ok]
    if np.any(np.diff(t) <= 0):
        raise MeasurementError(f'{path}: force time stamps are duplicated or not increasing')
    draft = -force[:, 2]
    if float(np.mean(draft)) < 0.0:
        msg = (f'{path}: the draft -Fz is negative on average ({np.mean(draft):.3g} N): wrong '
               'sign convention; give the force of the particles on the tool (draft = -Fz)')
        raise MeasurementError(msg)
    return t, force


def check_force_scale(path: Path, measured_n: float, model_n: float) -> None:
    """Raise MeasurementError when the mean draft differs from the model's by 100x or more.

    A factor of 1000 is a unit mistake (kN or mN for N), not a missing effect.
    """
    if model_n > 0 and measured_n > 0 and not 0.01 < measured_n / model_n < 100.0:
        msg = (f'{path}: mean draft {measured_n:.4g} against {model_n:.4g} N in the model: the '
               'force looks like it is in another unit (newtons expected)')
        raise MeasurementError(msg)
