"""The bed and the tool as a lab sets them up: carve vs slot, closed meshes, the re-settle."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import ConvexHull

from dempath_sim.engine.mesh import TriangleMesh, closest_point_triangle_numpy
from dempath_sim.engine.solid import open_edges, winding_numbers
from dempath_sim.engine.stl import read_stl, write_stl_ascii
from dempath_sim.errors import GeometryError, SceneError
from dempath_sim.runs.bed import fill_bed, packing_key
from dempath_sim.runs.bed.placement import place_tool, removal_mask
from dempath_sim.runs.native import _prepare_drive, pass_start_springs, resettle
from dempath_sim.runs.physics import build_params
from dempath_sim.scene import bundled_scene, load_scene
from dempath_sim.scene.loader import SCENES_DIR

LEAN = math.radians(35.0)  # the tine leans forward by this angle from the vertical


def leaning_tine(width: float = 0.03, thickness: float = 0.01, height: float = 0.12,
                 ) -> np.ndarray:
    """A closed, outward-oriented plate (12 triangles) whose top leans forward along +Z."""
    corners = np.array([(x, y, z) for x in (-width / 2, width / 2) for y in (0.0, height)
                        for z in (-thickness, 0.0)])
    corners[:, 2] += corners[:, 1] * math.tan(LEAN)
    hull = ConvexHull(corners)
    tris = corners[hull.simplices]
    normal = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    flip = np.einsum('ij,ij->i', normal, hull.equations[:, :3]) < 0
    tris[flip] = tris[flip][:, [0, 2, 1]]
    return tris


def grid_bed(spacing: float = 0.008) -> tuple[np.ndarray, np.ndarray]:
    """Sphere centres on a grid around the tine and their radii (touching neighbours)."""
    axes = [np.arange(-0.06, 0.06, spacing), np.arange(-0.02, 0.1, spacing),
            np.arange(-0.05, 0.12, spacing)]
    pos = np.stack(np.meshgrid(*axes, indexing='ij'), axis=-1).reshape(-1, 3)
    return pos, np.full(len(pos), spacing / 2)


def overlaps_mesh(point: np.ndarray, radius: float, tris: np.ndarray) -> bool:
    """Slow reference: centre inside (winding number) or surface closer than the radius."""
    inside = abs(winding_numbers(point[None], tris)[0]) > 0.5
    near = min(np.linalg.norm(point - closest_point_triangle_numpy(point, t)) for t in tris)
    return bool(inside or near < radius)


def test_tine_mesh_is_closed_and_winding_tells_inside() -> None:
    """The test tine and the shipped chisel are closed; winding is 1 inside, 0 outside."""
    tris = leaning_tine()
    assert open_edges(tris) == 0 and open_edges(read_stl(SCENES_DIR.parent / 'chisel.stl')) == 0
    assert open_edges(tris[1:]) > 0
    mid = np.array([[0.0, 0.06, 0.06 * math.tan(LEAN) - 0.005], [0.0, 0.06, -0.02]])
    np.testing.assert_allclose(winding_numbers(mid, tris), [1.0, 0.0], atol=1e-9)


def test_carve_removes_only_what_overlaps_the_leaning_tine() -> None:
    """The carve takes far fewer particles than the slot, and exactly those the mesh overlaps."""
    tris = leaning_tine()
    mesh = TriangleMesh(tris, name='tine')
    pos, radii = grid_bed()
    carve = removal_mask(pos, radii, mesh, (0.0, 0.0, 0.0), 'carve')
    slot = removal_mask(pos, radii, mesh, (0.0, 0.0, 0.0), 'slot')
    assert carve.sum() > 0 and carve.sum() < 0.5 * slot.sum()
    assert not (carve & ~slot).any()
    rng = np.random.default_rng(3)
    for k in rng.choice(np.flatnonzero(slot), 150, replace=False):
        assert carve[k] == overlaps_mesh(pos[k], radii[k], tris), k


def test_open_mesh_is_one_error_naming_the_file(tmp_path: Path) -> None:
    """Carving with an open mesh stops with one error naming the STL; the slot still works."""
    stl = tmp_path / 'open_tine.stl'
    write_stl_ascii(stl, leaning_tine()[1:], 'open')
    mesh = TriangleMesh.from_stl(stl)
    pos, radii = grid_bed()
    with pytest.raises(GeometryError, match=r'open_tine\.stl: the tool mesh is not closed'):
        removal_mask(pos, radii, mesh, (0.0, 0.0, 0.0), 'carve')
    assert removal_mask(pos, radii, mesh, (0.0, 0.0, 0.0), 'slot').any()
    text = (SCENES_DIR / 'tiny.yaml').read_text().replace('builtin:chisel.stl', str(stl))
    scene_file = tmp_path / 'scene.yaml'
    scene_file.write_text(text)
    with pytest.raises(SceneError, match=r'tool\.mesh: .*open_tine.stl.* is not a closed mesh'):
        load_scene(scene_file)
    scene_file.write_text(text.replace('  scale: 0.5', '  scale: 0.5\n  placement: slot'))
    assert load_scene(scene_file).tool.placement == 'slot'


@pytest.fixture(scope='module')
def tiny_bed(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, object]:
    """The tiny scene's bed, poured and settled once for this module."""
    cache = tmp_path_factory.mktemp('packings')
    scene = bundled_scene('tiny')
    bed = scene.bed_model()
    return cache, fill_bed(scene, bed, build_params(scene, bed), cache)


def test_resettle_builds_contact_history(tiny_bed: tuple[Path, object]) -> None:
    """A cached bed starts without springs; the re-settle against the tool loads them."""
    cache, _ = tiny_bed
    scene = bundled_scene('tiny')
    model = scene.physics_model()
    params = build_params(scene, model)
    state, report = fill_bed(scene, model, params, cache)
    assert report.from_cache
    drive, placed = _prepare_drive(scene, params, model, state, report)
    before = pass_start_springs(drive.engine)
    settled = resettle(drive, placed, scene.tool.settle_s)
    after = pass_start_springs(drive.engine)
    assert after > 0.5 * settled.n and before < 0.05 * after
    assert settled.time == 0.0 and drive.engine.tool_force[1] != 0.0


def test_effect_variants_reuse_the_scene_bed(tiny_bed: tuple[Path, object]) -> None:
    """Cohesion or rolling changes reuse the scene file's bed; fill.physics: run does not."""
    cache, _ = tiny_bed
    scene = bundled_scene('tiny')
    base = packing_key(scene, scene.bed_model())
    variants = [scene.with_overrides({'cohesion.energy_density_j_m3': 5e4}),
                scene.with_overrides(off=('rolling_resistance',))]
    for variant in variants:
        bed = variant.bed_model()
        assert packing_key(variant, bed) == base
        assert fill_bed(variant, bed, build_params(variant, bed), cache)[1].from_cache
        own = replace(variant, fill=replace(variant.fill, physics='run'))
        assert packing_key(own, own.bed_model()) != base
    coarse = scene.with_overrides({'particle_size.coarse_grain': 1.5})
    assert packing_key(coarse, coarse.bed_model()) != base


def test_run_places_the_tool_by_carve(tiny_bed: tuple[Path, object]) -> None:
    """The tiny scene's carve removes fewer particles than its slot."""
    _, (state, report) = tiny_bed
    scene = bundled_scene('tiny')
    mesh = TriangleMesh.from_stl(scene.tool.mesh, scale=scene.tool.scale)
    from dempath_sim.runs.bed.placement import tool_start

    start = tool_start(scene, report)
    _, carved = place_tool(state, mesh, start, 'carve')
    _, slotted = place_tool(state, mesh, start, 'slot')
    assert 0 < carved < slotted


def poured_tiny(tmp_path: Path, reference: str = 'nominal_surface') -> Path:
    """The tiny scene with its bed poured around the standing chisel (a scene file)."""
    text = (SCENES_DIR / 'tiny.yaml').read_text().replace(
        '  scale: 0.5', f'  scale: 0.5\n  placement: poured\n  depth_reference: {reference}')
    path = tmp_path / 'poured.yaml'
    path.write_text(text)
    return path


def test_poured_needs_the_tool_placed_below_the_nominal_surface(tmp_path: Path) -> None:
    """The tool stands in the bin before the bed settles: its depth cannot follow the settled
    surface, and LIGGGHTS' own pours have no tool in them."""
    from dempath_sim.liggghts.backend import LiggghtsBackend

    with pytest.raises(SceneError, match=r'tool\.placement: poured places the tool before'):
        load_scene(poured_tiny(tmp_path, 'settled_surface'))
    scene = load_scene(poured_tiny(tmp_path))
    with pytest.raises(SceneError, match=r"tool\.placement: poured: .*fill 'shared_pour'"):
        LiggghtsBackend(tmp_path / 'lig').run(scene)


def test_bed_poured_around_the_tool_rests_against_it(tmp_path: Path,
                                                     tiny_bed: tuple[Path, object]) -> None:
    """A poured bed is the tool's own packing (another key), no grain centre lies inside the
    standing tool, grains rest against it, and the run's placement removes none of them."""
    cache, _ = tiny_bed
    carve = bundled_scene('tiny')
    scene = load_scene(poured_tiny(tmp_path))
    bed = scene.bed_model()
    key = packing_key(scene, bed)
    assert key != packing_key(carve, carve.bed_model())
    moved = replace(scene, tool=replace(scene.tool, start_z_m=scene.tool.start_z_m + 0.01))
    assert packing_key(moved, bed) != key
    state, report = fill_bed(scene, bed, build_params(scene, bed), cache)
    mesh = TriangleMesh.from_stl(scene.tool.mesh, scale=scene.tool.scale)
    from dempath_sim.runs.bed.standing_tool import nominal_start

    start = nominal_start(scene)
    touching = removal_mask(state.positions, state.radii, mesh, start, 'carve')
    assert touching.sum() >= 5  # the bed settled against the tool
    assert not removal_mask(state.positions, state.radii, mesh, start, 'poured').any()
    assert place_tool(state, mesh, start, 'poured')[1] == 0
    tris = mesh.triangles + np.asarray(start)
    assert (np.abs(winding_numbers(state.positions, tris)) < 0.5).all()
    assert report.n_particles == state.n


def test_the_tool_moves_when_it_removes_nothing(tmp_path: Path,
                                                tiny_bed: tuple[Path, object]) -> None:
    """A bed poured around the tool loses no grain to it, and the tool still drives (the count
    of removed grains once landed in the drive's stop time, freezing such a tool at t = 0)."""
    from dempath_sim.runs import RunOptions, run_scene

    cache, _ = tiny_bed
    scene = load_scene(poured_tiny(tmp_path))
    short = replace(scene, tool=replace(scene.tool, travel_m=0.02))
    result = run_scene(short, RunOptions(cache_dir=cache))
    assert result.meta['removed_by_tool'] == 0
    travelled = result.tool_position[-1, 2] - result.tool_position[0, 2]
    assert travelled == pytest.approx(0.02, abs=0.005)
    tiny = bundled_scene('tiny')
    carved = run_scene(replace(tiny, tool=replace(tiny.tool, travel_m=0.02)),
                       RunOptions(cache_dir=cache))
    assert carved.meta['removed_by_tool'] > 0
