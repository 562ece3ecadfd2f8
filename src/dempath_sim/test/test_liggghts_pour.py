"""LIGGGHTS fill from dempath's pour: same loose bed, same time step, same settle criterion."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from dempath.dumpio import frames_by_id, read_dump
from dempath_sim.engine.timestep import rayleigh_time_step
from dempath_sim.liggghts.fill_deck import POUR_DUMP, settle_lines
from dempath_sim.liggghts.install import LiggghtsInstall
from dempath_sim.runs.bed.pour import pour
from dempath_sim.runs.physics import build_params
from dempath_sim.scene import bundled_scene


def test_settle_stage_stops_like_dempath() -> None:
    """0.02 s checks, no stop before 0.1 s, last step at the first check >= the time limit."""
    scene = bundled_scene('tiny')
    dt = 0.01 / 36  # 0.02 s = 72 steps: 5 checks reach 0.1 s
    lines = settle_lines(scene, dt, 1, 0.6)
    assert 'run 72' in lines
    assert 'variable k1 loop 9' in settle_lines(scene, dt, 1, 0.6, 0.42)  # ceil(0.18 / 0.02)
    stop = [x for x in lines if x.startswith('if')]
    assert stop[0] == 'if "${k1} >= 5 && ${vm} < 0.03" then "jump SELF settled1"'
    assert stop[1] == 'if "${st} >= 2160" then "jump SELF settled1"'  # 30 checks x 72 steps


@pytest.mark.slow
@pytest.mark.liggghts
def test_shared_pour_fill_reads_dempath_pour(liggghts: LiggghtsInstall, tmp_path: Path) -> None:
    """For two seeds the LIGGGHTS fill starts from exactly dempath's pour (count, ids, radii,
    positions, velocities), keeps every sphere, runs at dempath's time step and stops at the
    first 0.02 s check at or after the settle time limit."""
    from dempath_sim.liggghts.backend import fill_liggghts

    base = bundled_scene('tiny')
    short = dataclasses.replace(base.fill, max_settle_time_s=0.1)
    for seed in (1, 2):
        scene = dataclasses.replace(base.with_overrides(seed=seed), fill=short)
        model = scene.physics_model()
        params = build_params(scene, model)
        loose = pour(scene, model, params)
        bed = fill_liggghts(scene, tmp_path / f's{seed}')
        first = read_dump(tmp_path / f's{seed}' / POUR_DUMP)[0]
        got = frames_by_id([first], loose.ids + 1, ('x', 'y', 'z', 'vx', 'vy', 'vz', 'radius'))[0]
        assert len(first.column('id')) == loose.n
        assert np.allclose(got[:, :3], loose.positions, rtol=0, atol=1e-6)  # %g dump
        assert np.allclose(got[:, 3:6], loose.velocities, rtol=1e-5, atol=1e-9)
        assert np.allclose(got[:, 6], loose.radii, rtol=1e-5)
        assert len(bed.ids) == loose.n  # nothing lost while settling
        assert np.array_equal(np.sort(bed.ids), np.sort(loose.ids) + 1)
        dt = params.rayleigh_safety * rayleigh_time_step(loose.radii, loose.material, params)
        assert bed.report['dt_s'] == pytest.approx(dt, rel=1e-12)
        check = round(0.02 / dt) * dt
        assert bed.report['settle_time_s'] == pytest.approx(math.ceil(0.1 / check) * check)
        assert 0.3 < bed.report['solid_fraction'] < 0.7
