"""A model at any strength of one candidate, from the library's paired runs (no simulation).

The library ran each candidate at a few strengths on the baseline's packing seeds, re-settled
from the same beds, so a particle keeps its id across the runs of one seed. The model at
strength x on seed s is the baseline run of s plus, particle by particle, the paired difference
(candidate run minus baseline run, same seed) interpolated piecewise-linearly in x between the
library's strengths (log x for log-scale effects) and extrapolated from the end segments: the
emulator of :mod:`dempath_diagnose.decision.emulator` applied to whole paths instead of group
statistics.
A particle missing from one of the runs is left out. It is what the headline error of a fitted
strength is computed on when no real run at that strength exists; a real run replaces it.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dempath_diagnose.library.store import Library
from dempath_diagnose.records import F64, PassRecord
from dempath_sim.effects.candidates import LOG_SCALE


def _weights(knots: list[float], x: float, log: bool) -> dict[int, float]:
    """Interpolation weights {knot index: weight} at ``x`` (linear extrapolation at the ends)."""
    u = np.log(np.asarray(knots)) if log else np.asarray(knots, np.float64)
    v = float(np.log(x)) if log else float(x)
    order = np.argsort(u)
    u = u[order]
    i = int(np.clip(np.searchsorted(u, v) - 1, 0, len(u) - 2))
    w = (v - u[i]) / (u[i + 1] - u[i])
    return {int(order[i]): 1.0 - w, int(order[i + 1]): w}


def emulated_run(library: Library, candidate: str, strength: float, seed: int) -> PassRecord:
    """The model with ``candidate`` at ``strength`` on packing seed ``seed`` (see the module
    docstring); ``candidate`` '' is the baseline run itself."""
    base_file = next(r.filename for r in library.runs if r.seed == seed and not r.candidate)
    base = library.records[base_file]
    if not candidate:
        return base
    cand = next(c for c in library.candidates if c.name == candidate)
    runs = sorted((r for r in library.runs if r.candidate == candidate and r.seed == seed),
                  key=lambda r: r.strength)
    knots = [cand.current] + [r.strength for r in runs]
    recs = [base] + [library.records[r.filename] for r in runs]
    weights = _weights(knots, strength, candidate in LOG_SCALE)
    common = base.ids
    for rec in recs[1:]:
        common = np.intersect1d(common, rec.ids)
    pos = np.asarray(base.positions[:, _index(base.ids, common)], np.float64)
    ref = pos.copy()
    for k, w in weights.items():
        if k == 0 or w == 0.0:
            continue
        rec = recs[k]
        other = _at_times(rec.times, np.asarray(rec.positions[:, _index(rec.ids, common)],
                                                np.float64), base.times)
        pos += w * (other - ref)
    meta = {**base.meta, 'emulated': {'candidate': candidate, 'strength': float(strength)}}
    return PassRecord(base.times, common, pos.astype(np.float32), base.tool_position,
                      base.force_times, base.tool_force, meta)


def _at_times(times: F64, values: F64, wanted: F64) -> F64:
    """(len(wanted), ...) ``values`` (nt, ...) at ``wanted`` times (linear; NaN past the end)."""
    j = np.clip(np.searchsorted(times, wanted, side='right') - 1, 0, len(times) - 2)
    w = ((wanted - times[j]) / (times[j + 1] - times[j])).reshape((-1,) + (1,) * (values.ndim - 1))
    out = values[j] * (1.0 - w) + values[j + 1] * w
    out[wanted > times[-1] + 1e-9] = np.nan
    return np.asarray(out)


def _index(ids: NDArray[np.int64], wanted: NDArray[np.int64]) -> NDArray[np.intp]:
    order = np.argsort(ids)
    return order[np.searchsorted(ids[order], wanted)]
