"""t = 0 of a measured pass: a bag's camera-clock stamps against a CSV's pass time.

The reconstructor stamps its MarkerPoints3D with the cameras' clock (seconds since 1970), while
the diagnosis works in pass time (t = 0 when the tool starts to move). A bag's pass start is the
pass node's STARTED RunEvent when recorded, else its first marker sample; a CSV holding clock
times is one clear error.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from dempath import topics
from dempath.bagio import write_bag
from dempath.typestore import make_typestore
from dempath_diagnose.decision.measure import load_tracks
from dempath_diagnose.errors import MeasurementError

from .test_bad_input import moving, write_markers

CLOCK_S = 1_700_000_000.25  # the cameras' clock at the pass start [s]


def stamp_of(store: Any, t: float) -> Any:
    """builtin_interfaces/Time of ``t`` seconds."""
    ns = round(t * 1e9)
    return store.types['builtin_interfaces/msg/Time'](sec=ns // 10**9, nanosec=ns % 10**9)


def clock_bag(path: Path, pass_start: float | None, lead_s: float) -> Path:
    """Markers 1 and 2 of :func:`moving`, stamped ``CLOCK_S + t``, recorded from ``lead_s``
    before the pass start (the markers resting then), with a pass-start event at
    ``pass_start`` (None: no event)."""
    store = make_typestore()
    header, point = store.types['std_msgs/msg/Header'], store.types[
        'dempath_msgs/msg/MarkerPoints3D']
    rows = {m: moving(m) for m in (1, 2)}
    times = [-lead_s + 0.02 * i for i in range(round(lead_s / 0.02))] + [r[0] for r in rows[1]]
    nan = np.full(2, np.nan)
    msgs = []
    for t in times:
        k = max(0, round(t / 0.02))
        xyz = np.array([rows[m][k][2:] for m in (1, 2)])
        ns = round((CLOCK_S + t) * 1e9)
        msg = point(header=header(stamp=stamp_of(store, CLOCK_S + t), frame_id='world'),
                    method='dlt', marker_ids=np.array([1, 2], np.int32),
                    x=np.ascontiguousarray(xyz[:, 0]), y=np.ascontiguousarray(xyz[:, 1]),
                    z=np.ascontiguousarray(xyz[:, 2]), sigma_x=nan, sigma_y=nan, sigma_z=nan,
                    reprojection_error=nan.astype(np.float32))
        msgs.append((topics.MARKER_POINTS, 'dempath_msgs/msg/MarkerPoints3D', ns, msg))
    if pass_start is not None:
        event = store.types['dempath_msgs/msg/RunEvent'](
            header=header(stamp=stamp_of(store, pass_start), frame_id=''), run_id='pass_1',
            event=0, detail='')
        msgs.append((topics.PASS_EVENTS, 'dempath_msgs/msg/RunEvent',
                     round(pass_start * 1e9), event))
    msgs.sort(key=lambda m: m[2])
    return write_bag(path, msgs, typestore=store)


def test_bag_pass_time_from_the_pass_start_event(tmp_path: Path) -> None:
    """Recorded 0.2 s before the pass started: the event's stamp is t = 0, as in the CSV."""
    csv = load_tracks(write_markers(tmp_path / 'm.csv', moving(1) + moving(2)))
    bag = load_tracks(clock_bag(tmp_path / 'bag', CLOCK_S, lead_s=0.2))
    assert 'pass start on /markers/pass_events' in bag.time_origin and not csv.time_origin
    assert bag.times[0] == 0.0 and abs(bag.times[-1] - csv.times[-1]) < 1e-9
    np.testing.assert_allclose(bag.positions, csv.positions, atol=1e-6)  # ns stamps near 1.7e9 s


def test_bag_without_an_event_starts_at_its_first_sample(tmp_path: Path) -> None:
    """No pass-start event: t = 0 at the first marker sample, and the output says so."""
    bag = load_tracks(clock_bag(tmp_path / 'bag', None, lead_s=0.0))
    csv = load_tracks(write_markers(tmp_path / 'm.csv', moving(1) + moving(2)))
    assert 'first marker sample' in bag.time_origin
    np.testing.assert_allclose(bag.positions, csv.positions, atol=1e-6)


def test_csv_with_clock_times_is_one_clear_error(tmp_path: Path) -> None:
    """A CSV whose t is the camera clock: one error naming the file, not a huge time base."""
    rows = [(CLOCK_S + t, m, x, y, z) for t, m, x, y, z in moving(1)]
    with pytest.raises(MeasurementError, match='clock time'):
        load_tracks(write_markers(tmp_path / 'clock.csv', rows))
