"""Held-out markers: left out of the diagnosis and the fit, scored apart before and after."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from dempath_diagnose.entry.diagnosis import measurement_of
from dempath_diagnose.entry.requests import DiagnoseRequest
from dempath_diagnose.errors import DiagnosisError, MeasurementError
from dempath_diagnose.library.simulator import load_scene
from dempath_diagnose.records import Measurement

BAGS = Path(__file__).resolve().parents[3] / 'bags'


def test_split_keeps_the_fit_markers_and_the_held_out_apart() -> None:
    """The fit part keeps the force; the held-out part has the held-out markers alone."""
    pos = np.arange(4 * 5 * 3, dtype=float).reshape(4, 5, 3)
    meas = Measurement(np.arange(1, 6), np.linspace(0, 0.3, 4), pos, np.zeros(2),
                       np.ones((2, 3)))
    fit, held = meas.split((2, 5))
    assert fit.markers.tolist() == [1, 3, 4] and held.markers.tolist() == [2, 5]
    assert np.array_equal(held.positions, pos[:, [1, 4]]) and fit.has_force
    assert not held.has_force


def test_the_diagnosis_leaves_the_held_out_markers_out(tmp_path: Path,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    """measurement_of drops the held-out markers and says so; one that was not measured, or a
    held-out set that leaves too few to diagnose, is one clear error naming the option."""
    truth = json.loads((BAGS / 'field_twin_tiny.truth.json').read_text())
    origin = tuple(truth['field_origin_in_scene_m'])
    scene = load_scene('builtin:tiny')

    def request(held: tuple[int, ...]) -> DiagnoseRequest:
        return DiagnoseRequest(BAGS / 'field_twin_tiny.truth.csv', 'builtin:tiny', tmp_path,
                               origin=origin, held_out=held)

    meas = measurement_of(request((3, 8, 13)), scene)
    assert sorted(meas.markers.tolist()) == [m for m in range(1, 16) if m not in (3, 8, 13)]
    assert 'markers 3, 8, 13 held out' in capsys.readouterr().err
    with pytest.raises(MeasurementError, match=r'--held-out 3,99: marker\(s\) \[99\] not in'):
        measurement_of(request((3, 99)), scene)
    with pytest.raises(MeasurementError, match='leaves 1 marker'):
        measurement_of(request(tuple(range(1, 15))), scene)
    with pytest.raises(DiagnosisError, match='distinct'):
        request((3, 3))
