"""Message <-> numpy conversions of the diagnosis node."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dempath_diagnose.diagnose import Diagnosis, sentences
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


def diagnosis_msg(result: Diagnosis, case_id: str, header: Any) -> DiagnosisMsg:
    """The Diagnosis message: ranked candidates and '<verdict>: <first sentence>'."""
    out = DiagnosisMsg(header=header, case_id=case_id)
    out.verdict = f'{result.decision.verdict}: {sentences(result)[0]}'
    for fit in result.decision.ranking:
        out.candidates.append(EffectCandidate(
            effect=fit.name, probability=float(fit.probability),
            explained_error=float(fit.explained_fraction),
            fitted_strength=float(fit.strength) if math.isfinite(fit.strength) else 0.0,
            strength_parameter=fit.parameter, strength_unit=fit.unit))
    return out
