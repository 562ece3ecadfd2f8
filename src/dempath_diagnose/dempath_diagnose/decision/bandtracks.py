"""A model band as dempath_compare tracks, and the paper's Table 7 of a band against a measurement.

A *band* is a model's library runs over packing seeds
(:class:`~dempath_diagnose.records.PassRecord`). A measured marker's model counterparts are
the particles whose start lies in the candidate cube around its measured start
(:func:`~dempath_diagnose.library.counterparts.cube_members`, the paper's Cube candidates,
any layout), in every run of the band; each becomes a
:class:`dempath_compare.records.Track` tagged with the marker's number, so that dempath_compare
scores each marker against its own candidates only (``Pairing.MARKER``) and builds the paper's
Table 7 (per marker MAE, RMSE, range and nRMSE over the N best candidates; Kuře & Kuřetová 2025)
and its mean nRMSE. The diagnosis reports it for the baseline band (``error_before``); the
recalibration, for the recalibrated one.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from dempath_diagnose.library.counterparts import cube_members
from dempath_diagnose.records import F64, Measurement, PassRecord

TOP_N = 10  # best candidates per marker in Table 7 (the paper's N)
MEASURED_GROUP = 'measured'


def measured_tracks(meas: Measurement, group: str = MEASURED_GROUP) -> list[Any]:
    """One Track per measured marker (its finite samples), scene frame [m], [s]."""
    from dempath_compare.records import Track

    out = []
    for j, marker in enumerate(meas.markers.tolist()):
        ok = np.isfinite(meas.positions[:, j]).all(1)
        out.append(Track(f'{group}/marker{marker}', group, int(marker), int(marker),
                         meas.times[ok], meas.positions[ok, j], run_id=group))
    return out


def band_tracks(records: Sequence[PassRecord], markers: Sequence[int], starts: F64,
                cube: tuple[float, float, float], end_s: float = math.inf,
                names: Sequence[str] = ()) -> list[Any]:
    """The model counterparts of each marker in every run of a band, as Tracks.

    Args:
        records: The band's runs (one per packing seed).
        markers: (m,) marker numbers.
        starts: (m, 3) measured start positions in the scene frame [m].
        cube: Candidate cube size (X, Y, Z) [m].
        end_s: Frames after this time are left out (the measured window) [s].
        names: Run names (default ``run<k>``); a track is ``<run>/<particle>/m<marker>``.

    Returns:
        Tracks with ``marker_id`` the marker they are a candidate of, ``group`` and ``run_id``
        the run, ``seed`` the packing seed (from the record's meta).
    """
    from dempath_compare.records import Track

    out = []
    for k, rec in enumerate(records):
        run = names[k] if k < len(names) else f'run{k}'
        seed = int(rec.meta.get('seed', -1))
        keep = rec.times <= end_s + 1e-9
        times = rec.times[keep]
        for j, idx in enumerate(cube_members(rec.start, starts, cube)):
            for i in idx.tolist():
                p = np.asarray(rec.positions[keep, i], np.float64)
                ok = np.isfinite(p).all(1)
                pid = int(rec.ids[i])
                out.append(Track(f'{run}/{pid}/m{markers[j]}', run, pid, int(markers[j]),
                                 times[ok], p[ok], run_id=run, seed=seed))
    return out


def model_record(tracks: Sequence[Any]) -> PassRecord:
    """A user's own model run (dempath_compare tracks: a LIGGGHTS dump, a mapped EDEM/Rocky
    CSV, dempath's CSV) as one band run: every particle's positions on the union of the tracks'
    times, NaN where a track has no sample; no tool force (Table 7 does not use it)."""
    times = np.unique(np.concatenate([np.asarray(t.times, np.float64) for t in tracks]))
    positions = np.full((len(times), len(tracks), 3), np.nan, np.float32)
    for j, track in enumerate(tracks):
        positions[np.searchsorted(times, track.times), j] = track.positions
    zeros = np.zeros((len(times), 3))
    return PassRecord(times=times, ids=np.array([t.ident for t in tracks], np.int64),
                      positions=positions, tool_position=zeros, force_times=times,
                      tool_force=zeros, meta={'seed': -1})


def band_table7(meas: Measurement, records: Sequence[PassRecord],
                cube: tuple[float, float, float], names: Sequence[str] = (),
                top_n: int = TOP_N) -> dict[str, Any]:
    """The paper's Table 7 of a band against the measured markers, as JSON-ready data.

    Returns:
        ``rows`` (per marker: n_best, MAE and RMSE mean and sd [m], range [m], nRMSE [%]),
        ``mean_nrmse_pct`` (NaN when no marker could be scored), ``top_n``, ``model_runs``,
        ``markdown`` (dempath_compare's table) and ``unscored`` (marker: why).
    """
    from dempath_compare.config import CompareConfig, Pairing
    from dempath_compare.pipeline import compare_tracks
    from dempath_compare.summary import build_table7, table7_markdown

    markers = [int(m) for m in meas.markers]
    config = CompareConfig(top_n=top_n, pairing=Pairing.MARKER, cube_size=cube,
                           marker_ids=tuple(markers), match_speed=False)
    result = compare_tracks(measured_tracks(meas),
                            band_tracks(records, markers, meas.start, cube,
                                        float(meas.times[-1]), names), config)
    table = build_table7(result, top_n)
    rows = [{'marker': r.marker, 'n_best': r.n_best, 'mae_m': r.mae_mean, 'mae_sd_m': r.mae_std,
             'rmse_m': r.rmse_mean, 'rmse_sd_m': r.rmse_std, 'range_m': r.range_m,
             'nrmse_pct': r.nrmse} for r in table.rows]
    scored = {r['marker'] for r in rows}
    nrmse = [r['nrmse_pct'] for r in rows if math.isfinite(r['nrmse_pct'])]
    return {'rows': rows, 'mean_nrmse_pct': float(np.mean(nrmse)) if nrmse else math.nan,
            'top_n': top_n, 'model_runs': len(records),
            'unscored': {str(m): 'no model candidate could be scored' for m in markers
                         if m not in scored},
            'markdown': table7_markdown(table)}
