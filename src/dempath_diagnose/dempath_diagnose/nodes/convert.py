"""Message <-> numpy conversions of the diagnosis node."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dempath_diagnose.decision.diagnosis import Diagnosis, sentences
from dempath_msgs.msg import Diagnosis as DiagnosisMsg
from dempath_msgs.msg import EffectCandidate


def marker_frame(msg: Any) -> tuple[float, NDArray[np.int64], NDArray[np.float64]]:
    """(t [s], marker ids (n,), positions (n, 3) [m]) of a MarkerPoints3D."""
    t = float(msg.header.stamp.sec) + 1e-9 * float(msg.header.stamp.nanosec)
    xyz = np.stack([np.asarray(msg.x), np.asarray(msg.y), np.asarray(msg.z)], axis=1)
    return t, np.asarray(msg.marker_ids, np.int64), xyz.reshape(-1, 3)


def force_sample(msg: Any) -> tuple[float, NDArray[np.float64]]:
    """(t [s], force (3,) [N]) of a ToolForce (header stamp, the measured clock)."""
    t = float(msg.header.stamp.sec) + 1e-9 * float(msg.header.stamp.nanosec)
    f = msg.wrench.force
    return t, np.array([f.x, f.y, f.z], np.float64)


def _finite(x: float) -> float:
    return float(x) if math.isfinite(x) else 0.0


def diagnosis_msg(result: Diagnosis, case_id: str, header: Any) -> DiagnosisMsg:
    """The Diagnosis message: what diagnosis.json holds, candidates ranked most probable first.

    Statistics not measured (the draft without a force) have NaN as measured value.
    """
    dec = result.decision
    summary = sentences(result)
    measured = np.full(len(result.emulator.names), np.nan)
    measured[np.flatnonzero(result.observed)] = result.measured
    out = DiagnosisMsg(header=header, case_id=case_id)
    out.verdict = f'{dec.verdict}: {summary[0]}'
    out.verdict_code = dec.verdict
    out.summary = summary
    out.baseline_probability = float(dec.baseline.probability)
    out.baseline_implausibility = float(dec.baseline.implausibility)
    out.statistic_names = list(result.emulator.names)
    out.floor = result.floor.astype(np.float64).tolist()
    out.measured = measured.tolist()
    out.model = result.emulator.mu0.astype(np.float64).tolist()
    out.mean_nrmse_pct = float(result.table7.get('mean_nrmse_pct', math.nan))
    out.remaining = list(dec.remaining) if dec.verdict == 'inconclusive' else []
    out.would_separate = list(dec.separators)
    out.marker_problems = [f'marker {m}: {v}' for m, v in sorted(result.problems.items())]
    head = result.headline or {}
    out.headline_error_mm = float(head.get('value_mm', math.nan))
    floor = head.get('floor_mm', {})
    out.headline_floor_low_mm = float(floor.get('low', math.nan))
    out.headline_floor_high_mm = float(floor.get('high', math.nan))
    out.headline_place = str(head.get('place', ''))
    held = result.held_headline or {}
    if result.held_out is not None:
        out.held_out_markers = [int(m) for m in result.held_out.markers]
    out.held_out_headline_error_mm = float(held.get('value_mm', math.nan))
    held_floor = held.get('floor_mm', {})
    out.held_out_floor_low_mm = float(held_floor.get('low', math.nan))
    out.held_out_floor_high_mm = float(held_floor.get('high', math.nan))
    out.held_out_place = str(held.get('place', ''))
    out.simulations = int(result.simulations)
    out.wall_s = float(result.wall_s)
    for fit in dec.ranking:
        out.candidates.append(EffectCandidate(
            effect=fit.name, kind=fit.kind, probability=float(fit.probability),
            explained_error=float(fit.explained_fraction),
            fitted_strength=_finite(fit.strength), strength_uncertainty=_finite(fit.strength_sd),
            strength_parameter=fit.parameter, strength_unit=fit.unit,
            implausibility=float(fit.implausibility), ruled_out=bool(fit.ruled_out)))
    return out
