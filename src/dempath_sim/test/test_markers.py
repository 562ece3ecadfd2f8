"""Marker and candidate selection on a synthetic packing with a known surface."""

from __future__ import annotations

from dataclasses import replace

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
from dempath_sim.validation.deck_setup import NEAR_M, RAKED_TINE, pick_markers

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
    raw = yaml.safe_load(RAKED_TINE.scene_file().read_text())
    del raw['markers']['pick']
    assert scene_from_dict(raw, base_dir=RAKED_TINE.folder).markers.pick == 'exposed'
    raw['markers']['pick'] = 'top'
    assert scene_from_dict(raw, base_dir=RAKED_TINE.folder).markers.pick == 'top'
    raw['markers']['pick'] = 'highest'
    with pytest.raises(SceneError, match="pick: 'highest' is not one of exposed, top"):
        scene_from_dict(raw, base_dir=RAKED_TINE.folder)


def rough_bed(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """The raked-tine deck's 7 / 8 mm grains on a 7.5 mm lattice around its marker grid, the
    top layer at random heights over one spacing (some grains half-buried, as on a poured bed)."""
    rng = np.random.default_rng(seed)
    step = 0.0075
    xs = np.arange(-0.09, 0.09 + 1e-9, step)
    zs = np.arange(0.12, 0.38 + 1e-9, step)
    ys = -0.004 - np.arange(4) * step
    pos = np.stack(np.meshgrid(xs, ys, zs, indexing='ij'), axis=-1).reshape(-1, 3)
    pos[:, [0, 2]] += rng.uniform(-0.001, 0.001, (len(pos), 2))
    top = pos[:, 1] > -0.005
    pos[top, 1] -= rng.uniform(0.0, step, int(top.sum()))
    return pos, rng.choice([0.0035, 0.004], len(pos))


def marker_depth(pos: np.ndarray, rad: np.ndarray, index: list[int]) -> float:
    """Mean depth [m] of the grains' tops below the highest top within NEAR_M of each."""
    tops = pos[:, 1] + rad
    return float(np.mean([tops[np.hypot(*(pos[:, [0, 2]] - pos[i, [0, 2]]).T) < NEAR_M].max()
                          - tops[i] for i in index]))


def test_the_raked_deck_scene_picks_the_decks_surface_grains() -> None:
    """Issue 29's bin compares dempath's markers with a hand-written deck's "existing surface
    grains"; dempath's default rule took grains 2-3 mm deeper, which move less outward beside
    the tine (the issue's gap, docs/liggghts.md). The deck's scene file picks by the deck's
    rule: on rough beds of the deck's grains its markers are the deck's
    (``deck_setup.pick_markers``) at most grid points and sit as high, while the default rule's
    sit over a millimetre deeper."""
    spec = load_scene(RAKED_TINE.scene_file()).markers
    assert spec.pick == 'top'
    same, depths = [], []
    for seed in range(5):
        pos, rad = rough_bed(seed)
        ids = np.arange(len(pos))
        deck = pick_markers(ids, pos, RAKED_TINE.mean_r, RAKED_TINE.marker_z)
        deck_index = deck['axis'] + deck['right']
        scene = select_markers(pos, rad, ids, spec).particle_ids.tolist()
        default = select_markers(pos, rad, ids, replace(spec, pick='exposed')).particle_ids
        same.append(np.mean(np.array(scene) == np.array(deck_index)))
        depths.append([marker_depth(pos, rad, x) for x in (deck_index, scene, default.tolist())])
    deck_d, scene_d, default_d = np.mean(depths, axis=0)
    assert np.mean(same) >= 0.8, same
    assert abs(scene_d - deck_d) < 3e-4, depths
    assert default_d > deck_d + 1e-3, depths
