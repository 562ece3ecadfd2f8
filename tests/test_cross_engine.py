"""Cross-engine machinery on the tiny scene: dempath and LIGGGHTS, same physics, 3 seeds each."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dempath.nodes.pytest_plugin import require_component
from dempath_sim.liggghts.errors import LiggghtsNotFoundError
from dempath_sim.liggghts.install import LiggghtsInstall, ensure_liggghts
from dempath_sim.scene import bundled_scene
from dempath_sim.validation.cross_engine import (
    MarkerStats,
    compare,
    run_cross_engine,
    same_physics,
    saved_runs,
)


@pytest.fixture(scope='module')
def liggghts() -> LiggghtsInstall:
    """LIGGGHTS 3.8 (Debian package), installed by apt-get when root; else the test fails."""
    try:
        return ensure_liggghts(install=True)
    except LiggghtsNotFoundError as err:
        require_component('liggghts', err)


def test_same_physics_sets_dynamic_to_static_friction() -> None:
    """LIGGGHTS has one Coulomb coefficient, so the compared scene uses mu_d = mu_s everywhere."""
    scene = same_physics(bundled_scene('tiny'))
    for name in ('particle_friction', 'wall_friction', 'tool_friction'):
        values = scene.effects[name].values
        assert values['dynamic_friction'] == values['static_friction']


def test_ratio_is_difference_over_pooled_seed_spread() -> None:
    """Known series: engines 1 mm apart with a 1 mm seed spread give ratio 1; draft likewise."""
    t = np.linspace(0.0, 1.0, 11)

    def runs(offset: float) -> list[MarkerStats]:
        return [MarkerStats(t, np.full(11, offset + d), np.full(11, offset + d), 10 + offset + d)
                for d in (-1e-3, 0.0, 1e-3)]

    report = compare(runs(0.0), runs(1e-3), seeds=(1, 2, 3))
    assert report.ratios['axis'] == pytest.approx(1.0)
    assert report.ratios['lateral'] == pytest.approx(1.0)
    assert report.difference['draft'] == pytest.approx(1e-3)
    assert report.spread['draft'] == pytest.approx(1e-3)
    with pytest.raises(ValueError, match='at least 2 seeds'):
        compare(runs(0.0)[:1], runs(0.0), seeds=(1,))


@pytest.mark.slow
@pytest.mark.liggghts
def test_tiny_scene_agrees_loosely_across_engines(liggghts: LiggghtsInstall,
                                                  tmp_path: Path) -> None:
    """Both engines move the markers and resist the tool alike within a few seed spreads."""
    report = run_cross_engine(bundled_scene('tiny'), (1, 2, 3), tmp_path,
                              cache_dir=tmp_path / 'packings', results_dir=tmp_path / 'results')
    drafts = [s.draft for s in (*report.dempath, *report.liggghts)]
    assert min(drafts) > 0.0
    dem = np.mean([s.draft for s in report.dempath])
    lig = np.mean([s.draft for s in report.liggghts])
    assert 0.5 < dem / lig < 2.0
    axis_end = [np.nanmax(s.axis) for s in (*report.dempath, *report.liggghts)]
    assert min(axis_end) > 0.005  # the tool displaces the axis markers by millimetres at least
    assert report.cross_engine_ratio < 10.0, report.summary()
    # An interrupted comparison resumes: saved seeds are read back, nothing runs again.
    again = run_cross_engine(bundled_scene('tiny'), (1, 2, 3), tmp_path / 'again',
                             cache_dir=tmp_path / 'packings', results_dir=tmp_path / 'results')
    assert not (tmp_path / 'again').exists()
    assert again.ratios == report.ratios
    # ... but not for other effects: the saved runs are not theirs.
    assert saved_runs(tmp_path / 'results', same_physics(
        bundled_scene('tiny').with_overrides(on=('cohesion',), seed=1))) is None
