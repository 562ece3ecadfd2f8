"""The headline error of one model beside its floor, as every stage reports it.

The diagnosis (the model as it is), each recalibration (before and after, on the seeds the
evaluations ran) and the demo report give the same entry: the figure averaged over the
leave-one-seed-out pools of the model's S seeds (pools of S - 1 seeds) and the floor band of
the same model with pools of S - 1 seeds (:func:`~.floor.floor_band`), both on the measured
markers' own samples.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from dempath_diagnose.decision.diagnosis import Diagnosis
from dempath_diagnose.headline.floor import below_reason, floor_band, headline_figure
from dempath_diagnose.headline.samples import MarkerSamples
from dempath_diagnose.headline.score import headline_error
from dempath_diagnose.library.store import Library
from dempath_diagnose.records import Measurement, PassRecord


def headline_entry(meas: Measurement, model: Sequence[PassRecord],
                   cube: tuple[float, float, float], noise_m: float) -> dict[str, Any]:
    """The headline error [mm] of ``model`` (one run per packing seed, two or more) against
    ``meas``, its floor band and where it lies (JSON-ready).

    Raises:
        ValueError: Fewer than two seeds, or no marker could be scored.
    """
    if len(model) < 2:
        raise ValueError(f'headline_entry: {len(model)} model seed(s); two or more needed')
    pools = [[r for i, r in enumerate(model) if i != k] for k in range(len(model))]
    error = headline_error(meas, pools, cube)
    band = floor_band(MarkerSamples.of(meas), model, headline_figure(cube), noise_m,
                      len(model) - 1)
    place = band.place(error.value)
    return {'value_mm': error.value * 1e3,
            'per_marker_mm': {str(m): (None if not np.isfinite(v) else float(v) * 1e3)
                              for m, v in zip(error.markers, error.per_marker, strict=True)},
            'floor_mm': band.to_json(1e3), 'place': place,
            'why_below': below_reason(place, 'the headline error'),
            'model_seeds': len(model), 'pool_seeds': len(model) - 1}


def baseline_headline(meas: Measurement, library: Library, cube: tuple[float, float, float],
                      noise_m: float) -> dict[str, Any]:
    """The headline error of the library's baseline beside its floor (``error`` instead when
    it cannot be scored: fewer than two seeds, no marker with model candidates)."""
    files = [f for runs in library.model_runs('').values() for f in runs]
    try:
        return headline_entry(meas, [library.records[f] for f in files], cube, noise_m)
    except ValueError as err:
        return {'error': str(err)}


def with_headline(d: Diagnosis, library: Library, cube: tuple[float, float, float],
                  noise_m: float) -> Diagnosis:
    """``d`` with the headline error of the library's baseline on the measurement it diagnosed
    (what every reported diagnosis carries: the command's, the demo's and the node's)."""
    assert d.measurement is not None
    d.headline = baseline_headline(d.measurement, library, cube, noise_m)
    if d.held_out is not None:
        d.held_headline = baseline_headline(d.held_out, library, cube, noise_m)
    return d


def headline_sentence(entry: dict[str, Any], what: str) -> str:
    """One line: value, floor band and where it lies."""
    f = entry['floor_mm']
    where = {'above': 'above its floor: the model misses something chaos does not explain',
             'in': 'inside its floor: what the model itself gives over packing seeds',
             'below': 'below its floor band'}[entry['place']]
    line = (f"headline error {what} {entry['value_mm']:.2f} mm (floor band {f['low']:.2f}-"
            f"{f['high']:.2f} mm, the model played as the measurement with the same markers "
            f"and samples, pools of {entry['pool_seeds']} seed(s)): {where}")
    return line + (f"; {entry['why_below']}" if entry['why_below'] else '')


def held_out_sentence(entry: dict[str, Any]) -> str:
    """One line of the held-out check: the held-out markers' headline error before and after
    the fit, each beside its floor band ('' when either could not be scored)."""
    before, after = entry.get('before') or {}, entry.get('after') or {}
    if before.get('value_mm') is None or after.get('value_mm') is None:
        return ''
    fb, fa = before['floor_mm'], after['floor_mm']
    markers = ', '.join(map(str, entry['markers']))
    return (f'held-out markers {markers} (left out of the diagnosis and the fit): headline '
            f"error {before['value_mm']:.2f} mm ({before['place']} its floor band "
            f"{fb['low']:.2f}-{fb['high']:.2f}) -> {after['value_mm']:.2f} mm "
            f"({after['place']} {fa['low']:.2f}-{fa['high']:.2f})")
