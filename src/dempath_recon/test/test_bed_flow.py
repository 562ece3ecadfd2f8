"""Where the bed carried a marker no camera places (``tracking.bed_flow``): a measured field with
a still bed as prior, against the plain mean of the three nearest neighbours' displacements.

The scene is a bed of markers in three lateral lines 25 mm apart (X) and five along the travel
(Z), placed every frame for 10 frames: the tine pushes the line on its axis (X = 0) 3 mm a
frame along Z, the other lines stay. A marker of the still line beside it, unseen since the
first frame, stays where it was; one of the pushed line goes with its line.
"""

from __future__ import annotations

import numpy as np
import pytest

from dempath_recon.tracking.associate import MarkerGrid, MarkerPositions
from dempath_recon.tracking.bed_flow import TIME_SIGMA_M_S, carried_place
from dempath_recon.tracking.linker import UNNUMBERED
from dempath_recon.tracking.pair_numbering import PAIR_RATIO, only_marker
from dempath_recon.tracking.state import StereoState, carried_place_of, carried_point
from dempath_recon.tracking.stereo import StereoTrackConfig

DT = 0.02  # frame period [s]
FRAMES = 10
PUSH_M = 0.003  # the pushed line's step a frame along Z [m]
PITCH = 0.025  # marker spacing [m]
LINES = (0.0, PITCH, 2 * PITCH)  # lateral places of the three lines; the tine is on X = 0


def _bed() -> dict[int, np.ndarray]:
    """Marker -> (3,) m at the first frame: numbered line by line, five along the travel."""
    out = {}
    for i, x in enumerate(LINES):
        for j in range(5):
            out[1 + 5 * i + j] = np.array([x, 0.0, (j - 2) * PITCH])
    return out


def _at(start: np.ndarray, k: int) -> np.ndarray:
    """A marker starting at ``start`` at frame ``k`` (pushed when on the tine's line)."""
    return start + (np.array([0.0, 0.0, PUSH_M * k]) if start[0] == 0.0 else 0.0)


def _placed(unseen: set[int]) -> MarkerPositions:
    """The bed's accepted places over ``FRAMES`` frames; ``unseen`` placed at frame 0 only."""
    positions = MarkerPositions(gate_m=0.01, max_speed_m_s=2.0)
    for k in range(FRAMES):
        for m, start in _bed().items():
            if k == 0 or m not in unseen:
                positions.accept(m, k * DT, _at(start, k))
    return positions


def _state(bed_flow: bool, positions: MarkerPositions, rig) -> StereoState:
    """A two-camera tracker state holding ``positions`` (no frames seen)."""
    config = StereoTrackConfig(grid=MarkerGrid(layout_m=tuple(
        tuple(float(v) for v in p) for p in _bed().values())), bed_flow=bed_flow)
    state = StereoState.start({c.name: c for c in rig.cameras}, config)
    state.positions = positions
    return state


@pytest.mark.parametrize('bed_flow', [True, False])
def test_a_still_marker_beside_the_pushed_line_stays(bed_flow: bool, rig) -> None:
    """Marker 8 (the middle of the still line beside the tine) is unseen for 9 frames: the
    field keeps it within 2 mm of its place; three nearest neighbours (two still ones along
    the travel and the pushed one beside it) moved it a third of the push (9 mm)."""
    now = (FRAMES - 1) * DT
    state = _state(bed_flow, _placed({8}), rig)
    placed = carried_point(state, 8, now)
    assert placed is not None
    error = float(np.linalg.norm(placed[0] - _at(_bed()[8], FRAMES - 1)))
    if bed_flow:
        assert error < 0.002, error
    else:
        assert error > 0.005, error  # what the field mends


def test_a_pushed_marker_goes_with_its_line_and_says_it_is_less_sure() -> None:
    """Marker 3 (on the tine's line) unseen for 9 frames is carried with its pushed line
    within 6 mm (the still bed's prior holds it back a little), and its spread is larger
    than that of a still marker far from the tine (13, two lines off)."""
    now = (FRAMES - 1) * DT
    positions = _placed({3, 13})
    places = {m: carried_place(positions.history, m, now, positions.known[m], 1.5 * DT, 0.06)
              for m in (3, 13)}
    assert places[3] is not None and places[13] is not None
    true3 = _at(_bed()[3], FRAMES - 1)
    assert float(np.linalg.norm(places[3].xyz - true3)) < 0.006
    assert float(np.linalg.norm(places[3].xyz - _bed()[3])) > 0.015  # it did move
    assert float(np.linalg.norm(places[13].xyz - _bed()[13])) < 0.001
    assert places[3].sigma_m > places[13].sigma_m + 0.002  # both unseen as long
    assert places[3].since_s == 0.0


def test_the_spread_grows_with_time_unseen() -> None:
    """The same field read later (the neighbours' latest places kept recent) gives marker 13
    a larger spread: ``TIME_SIGMA_M_S`` per second unseen."""
    positions = _placed({13})
    early = carried_place(positions.history, 13, 4 * DT, positions.known[13], 1.5 * DT, 0.2)
    late = carried_place(positions.history, 13, 9 * DT, positions.known[13], 1.5 * DT, 0.2)
    assert early is not None and late is not None
    assert late.sigma_m > early.sigma_m
    assert late.sigma_m >= TIME_SIGMA_M_S * 9 * DT


def test_a_marker_without_a_neighbour_placed_at_both_ends_cannot_be_carried() -> None:
    """No measured motion over its gap: None, as the plain carried point."""
    positions = MarkerPositions(gate_m=0.01, max_speed_m_s=2.0)
    positions.accept(1, 0.0, np.zeros(3))
    positions.accept(2, 0.1, np.ones(3) * 0.01)
    assert carried_place(positions.history, 1, 0.2, positions.known[1], 0.03, 0.06) is None
    assert carried_place(positions.history, 1, 0.2, None, 0.03, 0.06) is None


def _torn(bed_flow: bool, rig) -> tuple[StereoState, float]:
    """Markers 1 (the rival) and 2 (10 mm behind it along the travel), both unseen since
    frame 0, among four neighbours 10 mm to either side along X whose motions disagree (the
    pair ahead pushed 20 mm along Z, the pair behind pulled back as much: the tine's edge).
    The field leaves 1 and 2 in place with a large spread."""
    positions = MarkerPositions(gate_m=0.01, max_speed_m_s=2.0)
    starts = {1: np.array([0.0, 0.0, 0.01]), 2: np.zeros(3)}
    moving = {3: (np.array([-0.01, 0.0, 0.01]), 1.0), 4: (np.array([0.01, 0.0, 0.01]), 1.0),
              5: (np.array([-0.01, 0.0, 0.0]), -1.0), 6: (np.array([0.01, 0.0, 0.0]), -1.0)}
    for m, at in starts.items():
        positions.accept(m, 0.0, at)
    for k in range(FRAMES):
        for m, (at, sign) in moving.items():
            positions.accept(m, k * DT, at + np.array([0.0, 0.0, sign * 0.02 * k / FRAMES]))
    layout = tuple(tuple(float(v) for v in p) for p in
                   [*starts.values(), *(a for a, _ in moving.values())])
    config = StereoTrackConfig(grid=MarkerGrid(layout_m=layout), bed_flow=bed_flow)
    state = StereoState.start({c.name: c for c in rig.cameras}, config)
    state.positions = positions
    return state, (FRAMES - 1) * DT


@pytest.mark.parametrize('bed_flow', [True, False])
def test_a_pair_a_rival_could_be_is_not_named(bed_flow: bool, rig) -> None:
    """A point 1 mm from where the field carried 2 and 11.5 mm from 1's place (1's spread 19
    mm) passes the distance ratio (``PAIR_RATIO``); on the plain carried points (1 at +16 mm,
    2 at -6 mm) it is named 2 too. With the field, 1's spread covers the point
    (``could_be_there``) and it is not named (the bunched markers in front of the tine: a
    pushed marker's place lags its true one)."""
    state, now = _torn(bed_flow, rig)
    two = carried_place_of(state, 2, now)
    one = carried_place_of(state, 1, now)
    assert two is not None and one is not None
    point = two.xyz + np.array([0.0, 0.0, -0.001])
    assert float(np.linalg.norm(point - one.xyz)) > PAIR_RATIO * 0.003
    assert float(np.linalg.norm(point - one.xyz)) < one.sigma_m
    assert only_marker(state, point, now, [1, 2]) == (UNNUMBERED if bed_flow else 2)
