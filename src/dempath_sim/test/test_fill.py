"""Filling: layer generation, bulk density measurement on known packings, the packing cache."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from dempath_sim.engine.state import SimState
from dempath_sim.runs.bed import fill_bed, measure, packing_key
from dempath_sim.runs.bed.pour import DEFAULT_SOLID_FRACTION, lattice, pour, sample_diameters
from dempath_sim.runs.physics import build_params
from dempath_sim.scene import bundled_scene
from dempath_sim.scene.spec import LayerSpec, SizeDistribution


def test_sample_diameters_fill_the_volume() -> None:
    """Sampled sphere volumes add up to the requested volume within one sphere."""
    rng = np.random.default_rng(0)
    layer = LayerSpec('top', 0.004, 0.1, SizeDistribution('uniform', 0.2))
    d = sample_diameters(layer, 3.0, 1e-3, rng)
    vol = np.sum(math.pi / 6 * d**3)
    assert 1e-3 <= vol <= 1e-3 + math.pi / 6 * d.max() ** 3
    assert d.min() >= 0.012 * 0.8 - 1e-12 and d.max() <= 0.012 * 1.2 + 1e-12


def test_discrete_distribution_mass_fractions() -> None:
    """A discrete distribution reproduces its mass fractions."""
    rng = np.random.default_rng(1)
    dist = SizeDistribution('discrete', 0.0, (0.002, 0.004), (0.25, 0.75))
    d = sample_diameters(LayerSpec('x', 0.003, 0.1, dist), 1.0, 2e-3, rng)
    mass = d**3
    assert mass[d == 0.004].sum() / mass.sum() == pytest.approx(0.75, abs=0.02)


def test_lattice_is_inside_and_does_not_overlap() -> None:
    """Generated centres stay in the bin and no two spheres overlap."""
    scene = bundled_scene('tiny')
    d = np.full(500, 0.012)
    pos, top = lattice(scene, d, -0.05, np.random.default_rng(2))
    half = scene.bin.width_x_m / 2
    assert (np.abs(pos[:, 0]) <= half - 0.006).all() and (pos[:, 2] >= 0.006).all()
    assert (pos[:, 2] <= scene.bin.length_z_m - 0.006).all() and (pos[:, 1] < top).all()
    gaps = np.linalg.norm(pos[:, None] - pos[None], axis=-1) + np.eye(len(pos))
    assert gaps.min() >= 0.012


def test_measure_on_simple_cubic_packing() -> None:
    """A simple-cubic packing measures solid fraction pi/6 and its top as the surface."""
    scene = bundled_scene('tiny')
    model = scene.physics_model()
    params = build_params(scene, model)
    d = 0.006
    xs = np.arange(-0.07 + d / 2, 0.07, d)
    zs = np.arange(d / 2, 0.22, d)
    ys = -0.048 + d / 2 + np.arange(8) * d
    grid = np.stack(np.meshgrid(xs, ys, zs, indexing='ij'), axis=-1).reshape(-1, 3)
    state = SimState.from_spheres(grid, d / 2, 0, params)
    found = measure(scene, model, state)
    assert found['surface_height_m'] == pytest.approx(-0.048 + 8 * d)
    assert found['solid_fraction'] == pytest.approx(math.pi / 6, rel=0.08)
    assert found['bulk_density_kg_m3'] == pytest.approx(1734 * found['solid_fraction'])


def test_pour_holds_the_target_mass_at_random_without_overlap() -> None:
    """The poured layers hold target solid fraction x layer volume of particles, inserted at
    random in the bin at the pour's solid fraction, no two overlapping."""
    scene = bundled_scene('tiny')
    model = scene.physics_model()
    state = pour(scene, model, build_params(scene, model))
    volume = np.sum(4 / 3 * np.pi * state.radii**3)
    nominal = scene.bin.width_x_m * scene.bin.length_z_m * scene.bed_thickness_m
    assert volume / nominal == pytest.approx(DEFAULT_SOLID_FRACTION, rel=0.02)
    pos, r = state.positions, state.radii
    gaps = np.linalg.norm(pos[:, None] - pos[None], axis=-1) - r[:, None] - r[None]
    assert (gaps + 3 * np.eye(len(r)) >= -1e-12).all()
    assert (np.abs(pos[:, 0]) + r <= scene.bin.width_x_m / 2 + 1e-12).all()
    slab = (pos[:, 1].max() + r.max() + scene.bed_thickness_m) * scene.bin.width_x_m * (
        scene.bin.length_z_m)
    assert 0.8 * scene.fill.pour_solid_fraction < volume / slab <= scene.fill.pour_solid_fraction
    again = pour(scene, model, build_params(scene, model))
    np.testing.assert_array_equal(again.positions, pos)


def test_packing_key_tracks_what_determines_the_packing() -> None:
    """Seed, layers and particle friction change the key; tool friction and speed do not
    (with the run's own physics: ``fill.physics: run``)."""
    scene = bundled_scene('tiny')
    key = packing_key(scene, scene.physics_model())
    same = [scene.with_overrides({'tool_friction.static_friction': 0.9}),
            scene.with_overrides({'tool_speed.speed_scale': 2.0})]
    other = [scene.with_overrides(seed=5),
             scene.with_overrides({'particle_friction.static_friction': 0.9}),
             replace(scene, layers=(replace(scene.layers[0], thickness_m=0.05),))]
    assert all(packing_key(s, s.physics_model()) == key for s in same)
    assert all(packing_key(s, s.physics_model()) != key for s in other)


@pytest.mark.slow
def test_fill_settles_and_caches(tmp_path_factory: pytest.TempPathFactory) -> None:
    """The tiny bed settles to a plausible packing and is read back from the cache."""
    cache = Path(tmp_path_factory.getbasetemp()) / 'packings'
    scene = bundled_scene('tiny')
    model = scene.physics_model()
    params = build_params(scene, model)
    state, report = fill_bed(scene, model, params, cache)
    assert 0.45 < report.solid_fraction < 0.66
    assert abs(report.surface_height_m) < 0.03
    assert (state.positions[:, 1] - state.radii > report.floor_y_m - 1e-3).all()
    again, cached = fill_bed(scene, model, params, cache)
    assert cached.from_cache and cached.key == report.key
    np.testing.assert_array_equal(again.positions, state.positions)


def test_bundled_packing_matches_reduced_scenes() -> None:
    """The shipped packing still belongs to the reduced scenes (else the demo refills)."""
    from dempath_sim.runs.bed import bundled_packing_dir, packing_key
    from dempath_sim.scene import bundled_scene

    for name in ('reduced_1ms', 'reduced_1_5ms'):
        scene = bundled_scene(name)
        key = packing_key(scene, scene.physics_model())
        assert (bundled_packing_dir() / f'{key}.npz').is_file(), (
            f'{name}: no bundled packing {key}.npz; rebuild it (data/packings/README.md)')


@pytest.mark.parametrize('damage', ['truncated', 'empty', 'no_report'])
def test_damaged_cache_entry_is_named_set_aside_and_replaced(
        tmp_path: Path, caplog: pytest.LogCaptureFixture, damage: str) -> None:
    """A truncated, empty or incomplete cached packing is named in a warning, moved to
    ``<name>.corrupt`` and the bed comes from elsewhere (here the shipped packing) instead of
    every run of the scene failing with BadZipFile until the file is deleted by hand."""
    import logging

    from dempath_sim.runs.bed import bundled_packing_dir

    scene = bundled_scene('reduced_1ms')
    model = scene.physics_model()
    params = build_params(scene, model)
    key = packing_key(scene, model)
    good = (bundled_packing_dir() / f'{key}.npz').read_bytes()
    entry = tmp_path / f'{key}.npz'
    if damage == 'truncated':
        entry.write_bytes(good[:len(good) // 2])
    elif damage == 'empty':
        entry.write_bytes(b'')
    else:
        with np.load(bundled_packing_dir() / f'{key}.npz') as data:
            np.savez(entry, **{k: data[k] for k in data.files if k != 'report'})
    with caplog.at_level(logging.WARNING, logger='dempath_sim.runs.bed.cache'):
        state, report = fill_bed(scene, model, params, tmp_path)
    assert report.from_cache and state.n > 1000
    assert not entry.exists() and (tmp_path / f'{key}.npz.corrupt').is_file()
    assert any(str(entry) in r.getMessage() and 'damaged' in r.getMessage()
               for r in caplog.records)
