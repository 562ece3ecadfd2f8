"""Marker and candidate selection on a synthetic packing with a known surface."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from dempath_sim.runs.markers import (
    ROLE_CANDIDATE,
    ROLE_MARKER,
    MarkerSelectionError,
    grid_xz,
    select_markers,
)
from dempath_sim.scene import SceneError, load_scene, scene_from_dict
from dempath_sim.scene.spec import MarkerSpec
from dempath_sim.validation.deck_setup import RAKED_TINE

D = 0.004  # grain diameter of the paper's top layer [m]


def cubic_bed(seed: int = 3) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Simple-cubic bed of 4 mm spheres, top centres at y = -2 mm, shuffled ids."""
    xs = np.arange(-0.1, 0.16 + 1e-9, D)
    zs = np.arange(0.9, 1.3 + 1e-9, D)
    ys = -D / 2 - np.arange(8) * D
    grid = np.stack(np.meshgrid(xs, ys, zs, indexing='ij'), axis=-1).reshape(-1, 3)
    ids = np.random.default_rng(seed).permutation(len(grid)) + 1000
    return grid, np.full(len(grid), D / 2), ids


def test_grid_numbering_follows_the_paper() -> None:
    """1-5 lie on the tool axis in travel order; rows 6-10 and 11-15 50 and 100 mm aside."""
    numbers, xz = grid_xz(MarkerSpec(first_z_m=1.0))
    assert numbers.tolist() == list(range(1, 16))
    np.testing.assert_allclose(xz[:5, 0], 0.0)
    np.testing.assert_allclose(xz[:5, 1], [1.0, 1.05, 1.1, 1.15, 1.2])
    np.testing.assert_allclose(xz[5:10, 0], 0.05)
    np.testing.assert_allclose(xz[10:, 0], 0.10)


def test_markers_are_surface_particles_nearest_the_grid() -> None:
    """Each marker is the top-layer sphere right at its grid point; ids survive shuffling."""
    pos, rad, ids = cubic_bed()
    sel = select_markers(pos, rad, ids, MarkerSpec(first_z_m=1.0))
    by_id = {int(i): p for i, p in zip(ids, pos, strict=True)}
    _, xz = grid_xz(MarkerSpec(first_z_m=1.0))
    for k, pid in enumerate(sel.particle_ids):
        p = by_id[int(pid)]
        assert p[1] == pytest.approx(-D / 2)
        assert np.hypot(p[0] - xz[k, 0], p[2] - xz[k, 1]) < D
    np.testing.assert_allclose(sel.grid_points[:, 1], 0.0, atol=1e-12)


def test_cube_candidates_count_and_roles() -> None:
    """The 30 x 20 x 10 mm cube holds the lattice's spheres: 7-8 x 5 x 2-3 per marker."""
    pos, rad, ids = cubic_bed()
    sel = select_markers(pos, rad, ids, MarkerSpec(first_z_m=1.0))
    for number in range(1, 16):
        count = len(sel.candidates_of(number))
        assert 7 * 5 * 2 <= count + 1 <= 8 * 5 * 3, count  # +1: the marker itself
    assert len(np.unique(sel.candidate_ids)) == len(sel.candidate_ids)
    assert not np.isin(sel.particle_ids, sel.candidate_ids).any()
    tracked, roles, markers = sel.tracked()
    assert (roles[:15] == ROLE_MARKER).all() and (roles[15:] == ROLE_CANDIDATE).all()
    assert markers[:15].tolist() == list(range(1, 16))
    assert len(tracked) == 15 + len(sel.candidate_ids)


def test_grid_outside_the_bed_is_an_error() -> None:
    """A grid point with no particle near it raises MarkerSelectionError naming the marker."""
    pos, rad, ids = cubic_bed()
    with pytest.raises(MarkerSelectionError, match='marker 1'):
        select_markers(pos, rad, ids, MarkerSpec(first_z_m=2.0))


def test_top_pick_takes_the_highest_grain_not_a_half_buried_one() -> None:
    """Beside a grain resting on top (centre at Y = 0) a half-buried grain lies right at the
    grid point (centre 5 mm lower, its top within one diameter of the surface): the default
    rule takes the buried one, ``pick: top`` (the hand-written decks' surface grain) the top
    one; a scene file reads the key and refuses another value."""
    pos = np.array([[0.0, -0.005, 1.0], [0.008, 0.0, 1.0]])
    rad = np.full(2, 0.004)
    ids = np.array([7, 8])
    grid = {'rows': 1, 'columns': 1, 'first_z_m': 1.0}
    assert select_markers(pos, rad, ids, MarkerSpec(**grid)).particle_ids.tolist() == [7]
    top = select_markers(pos, rad, ids, MarkerSpec(**grid, pick='top'))
    assert top.particle_ids.tolist() == [8]
    scene = load_scene(RAKED_TINE.scene_file())
    assert scene.markers.pick == 'exposed'
    raw = yaml.safe_load(RAKED_TINE.scene_file().read_text())
    raw['markers']['pick'] = 'top'
    assert scene_from_dict(raw, base_dir=RAKED_TINE.folder).markers.pick == 'top'
    raw['markers']['pick'] = 'highest'
    with pytest.raises(SceneError, match="pick: 'highest' is not one of exposed, top"):
        scene_from_dict(raw, base_dir=RAKED_TINE.folder)
