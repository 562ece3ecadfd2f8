"""The strength-coverage check on the tiny library: every left-out run fitted, sensibly."""

from __future__ import annotations

import numpy as np

from dempath_diagnose.decision.coverage import strength_checks, summary
from dempath_diagnose.decision.diagnosis import CaseGeometry
from dempath_diagnose.library.store import Library


def test_left_out_runs_are_fitted_near_their_own_strength(tiny_library: Library,
                                                           geometry: CaseGeometry) -> None:
    """Each left-out run, made a camera-like measurement, is fitted nearer its own strength
    than the scene's value when that strength differs much; z is finite and summarised."""
    base = next(tiny_library.records[r.filename] for r in tiny_library.runs if r.candidate == '')
    top = base.start[np.argsort(-base.start[:, 1])[:400]]
    pick = top[np.linspace(0, len(top) - 1, 6).astype(int)]
    checks = strength_checks(tiny_library, np.arange(1, 7, dtype=np.float64), pick,
                             geometry.tool_x_m, geometry.axis_half_width_m, geometry.cube_m)
    per_seed = sum(1 for r in tiny_library.runs if r.seed == 1001)
    n_cand = len(tiny_library.candidates)
    assert len(checks) == len(tiny_library.seeds()) * 2 * (n_cand + per_seed - 1)
    assert all(np.isfinite(c.z) and c.sd > 0 for c in checks)
    speed = [c for c in checks if c.candidate == 'tool_speed' and c.true != 1.0 and c.with_force]
    assert speed and all(abs(c.fitted - c.true) < abs(c.fitted - 1.0) for c in speed)
    figures = summary(checks)
    assert figures['all']['n'] == len(checks) and set(figures) >= {'all', 'tool_speed'}
