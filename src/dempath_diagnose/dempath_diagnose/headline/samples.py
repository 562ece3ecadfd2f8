"""Which markers a figure sees, and when: the contract a figure and its floor share.

A measured marker may be lost for part of the pass (buried, out of one camera's view). Every
figure (the headline error, Table 7) scores a marker where it was measured, and its floor must
see the same: the same markers, starting at the same places, at the same times. A
:class:`MarkerSamples` carries exactly that, and :func:`played_measurement` turns a model run
into a measurement with those samples (the k-th nearest particle to each marker start, with the
cameras' noise, NaN where the real marker was not measured), so a floor is never computed on
other markers, another window or complete paths beside a partial measurement.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dempath_diagnose.records import F64, Measurement, PassRecord


@dataclass(frozen=True)
class MarkerSamples:
    """The measured markers' starts and the times at which each was measured.

    Attributes:
        markers: (m,) marker numbers.
        starts: (m, 3) start positions, scene frame [m].
        times: (nt,) common times [s].
        present: (nt, m) True where the marker was measured.
    """

    markers: NDArray[np.int64]
    starts: F64
    times: F64
    present: NDArray[np.bool_]

    @classmethod
    def of(cls, meas: Measurement) -> MarkerSamples:
        """The samples of a measurement (a marker is present where its position is finite)."""
        return cls(meas.markers.copy(), meas.start, meas.times.copy(),
                   np.asarray(np.isfinite(meas.positions).all(2), np.bool_))

    def subset(self, keep: NDArray[np.bool_]) -> MarkerSamples:
        """Only the markers where ``keep`` (m,) is True."""
        return replace(self, markers=self.markers[keep], starts=self.starts[keep],
                       present=self.present[:, keep])

    def describe(self) -> list[dict[str, Any]]:
        """Per marker: first and last measured time [s] and the fraction of the pass covered."""
        out = []
        for j, m in enumerate(self.markers.tolist()):
            idx = np.flatnonzero(self.present[:, j])
            out.append({'marker': int(m),
                        'from_s': float(self.times[idx[0]]) if len(idx) else None,
                        'to_s': float(self.times[idx[-1]]) if len(idx) else None,
                        'covered': round(float(self.present[:, j].mean()), 3)})
        return out


def nearest_particles(rec: PassRecord, starts: F64, rank: int = 0) -> NDArray[np.intp]:
    """(m,) index of the ``rank``-th nearest particle (0: the nearest) to each start."""
    start = rec.start
    finite = np.isfinite(start).all(1)
    out = []
    for p in starts:
        dist = np.where(finite, np.linalg.norm(start - p, axis=1), np.inf)
        out.append(int(np.argsort(dist)[rank]))
    return np.array(out, np.intp)


def played_measurement(rec: PassRecord, samples: MarkerSamples, rank: int, noise_m: float,
                       rng: np.random.Generator) -> Measurement:
    """Model run ``rec`` as the measurement ``samples`` describe, like for like.

    Per marker, the ``rank``-th nearest particle to the marker's start, at the measured times
    (linear interpolation of the run's frames), with ``noise_m`` Gaussian noise per axis and
    sample, NaN where the real marker was not measured.
    """
    idx = nearest_particles(rec, samples.starts, rank)
    pos = np.full((len(samples.times), len(idx), 3), np.nan)
    for j, i in enumerate(idx):
        p = np.asarray(rec.positions[:, i], np.float64)
        for a in range(3):
            pos[:, j, a] = np.interp(samples.times, rec.times, p[:, a], right=np.nan)
    pos += rng.normal(0.0, noise_m, pos.shape)
    pos[~samples.present] = np.nan
    return Measurement(samples.markers.copy(), samples.times.copy(), pos)
