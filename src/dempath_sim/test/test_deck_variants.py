"""The hand-written decks' physics variants and dempath's scene of each agree.

The decks (``data/decks/leaning_tine``, issue 12; ``data/decks/raked_tine``, issue 29) are the
reference set-ups of the cross-engine checks; each candidate of the effects library is one of
their physics variants. The values a variant sets
in LIGGGHTS (``physics_<variant>.in``, the index variables of ``materials.in`` and ``in.pass``)
must be the ones dempath's scene of that variant runs with, or the check compares two physics.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from dempath_sim.engine import TriangleMesh
from dempath_sim.liggghts.install import LiggghtsInstall
from dempath_sim.scene import ToolPath
from dempath_sim.validation.cross_engine import same_physics
from dempath_sim.validation.deck_setup import (
    DECK_DIR,
    DECKS,
    MARKER_Z,
    RAKED_TINE,
    SIDE_X,
    VARIANTS,
    deck_frames,
    deck_stats,
    run_deck,
    same_bed_run,
    scene_for,
)

INDEX = re.compile(r'^variable\s+(\w+)\s+index\s+(\S+)', re.MULTILINE)


def deck_values(variant: str, folder: Path = DECK_DIR) -> dict[str, float]:
    """The sand's values a variant runs with in LIGGGHTS: its own index variables first, then
    the defaults of materials.in and in.pass (LIGGGHTS keeps the first definition)."""
    values: dict[str, float] = {}
    for path in (folder / f'physics_{variant}.in', folder / 'materials.in',
                 folder / 'in.pass'):
        for name, value in INDEX.findall(path.read_text()):
            if name not in ('deck', 'variant'):
                values.setdefault(name, float(value))
    return values


@pytest.mark.parametrize('name', sorted(DECKS))
@pytest.mark.parametrize('variant', sorted(VARIANTS))
def test_deck_and_scene_run_the_same_values(name: str, variant: str) -> None:
    """Young's modulus, restitution, the three Coulomb coefficients and the tine's speed and
    pass time of each variant are the same in the deck and in dempath's scene of it
    (LIGGGHTS' one coefficient per pair: static = dynamic)."""
    spec = DECKS[name]
    deck = deck_values(variant, spec.folder)
    scene = same_physics(scene_for(variant, scene_file=spec.scene_file()))
    model = scene.physics_model()
    assert model.particle_youngs_modulus_pa == pytest.approx(deck['E_sand'])
    effects = {name: scene.effects[name].values for name in scene.effects}
    assert effects['restitution']['particle_particle'] == pytest.approx(deck['e_rest'])
    assert effects['restitution']['particle_boundary'] == pytest.approx(deck['e_rest'])
    assert effects['particle_friction']['static_friction'] == pytest.approx(deck['mu_pp'])
    assert effects['wall_friction']['static_friction'] == pytest.approx(deck['mu_pw'])
    assert effects['tool_friction']['static_friction'] == pytest.approx(deck['mu_pt'])
    speed = scene.tool.profile.speed_m_s * model.speed_scale
    assert speed == pytest.approx(deck['speed'])
    profile = scene.tool.profile.scaled(model.speed_scale)
    pass_s = ToolPath(profile, (0.0, 0.0, 0.0)).time_to_travel(scene.tool.travel_m)
    assert deck['npass'] * 5e-5 == pytest.approx(pass_s, abs=0.005)


def test_raked_tine_is_the_issue_29_bar() -> None:
    """The raked deck's tine as issue 29 describes it: 35 mm wide, 12 mm thick, its axis
    leaning 25 deg from the vertical with the tip leading, 80 mm below and 80 mm above the
    nominal surface, the leading bottom edge at Z = 0.10 m; the scene places it there too."""
    v = TriangleMesh.from_stl(RAKED_TINE.folder / 'tine.stl', material=1).triangles.reshape(-1, 3)
    assert np.ptp(v[:, 0]) == pytest.approx(0.035)
    assert np.ptp(v[:, 1]) == pytest.approx(0.160)
    assert v[:, 2].max() == pytest.approx(0.0)  # the tip leads
    top = v[v[:, 1] > 0.1]
    assert np.degrees(np.arctan2(-top[:, 2].max(), 0.160)) == pytest.approx(25.0)
    bottom = v[np.abs(v[:, 1]) < 1e-12]
    assert np.ptp(bottom[:, 2]) * np.cos(np.radians(25.0)) == pytest.approx(0.012)
    scene = scene_for('base', scene_file=RAKED_TINE.scene_file())
    assert (scene.tool.depth_m, scene.tool.start_z_m) == (0.08, 0.10)
    assert scene.tool.placement == 'poured'
    tine_in = (RAKED_TINE.folder / 'tine.in').read_text()
    assert 'move 0.0 -0.080 0.100' in tine_in


@pytest.mark.parametrize('name', sorted(DECKS))
def test_unknown_deck_variant_is_one_clear_error(name: str, tmp_path: Path) -> None:
    """run.sh names a variant without a physics file before LIGGGHTS is started."""
    import subprocess

    done = subprocess.run(['sh', str(DECKS[name].folder / 'run.sh'), '1', 'sticky',
                           str(tmp_path)],
                          capture_output=True, text=True, check=False)
    assert done.returncode == 2
    assert 'variant: sticky: no physics_sticky.in' in done.stderr


def write_marker_bed(path: Path) -> None:
    """A bed of columns of ten 9 mm grains standing on the floor under each marker spot, their
    tops in the deck's surface zone (a LIGGGHTS data file): the tine knocks the axis columns
    over and passes the side ones, and a pass runs in seconds."""
    spots = [(x, z) for x in (-SIDE_X, 0.0, SIDE_X) for z in MARKER_Z]
    grains = [(x, -0.0955 + 0.009 * j, z) for x, z in spots for j in range(10)]
    rows = [f'{k + 1} 1 0.009 1734 {x:.4f} {y:.4f} {z:.4f}' for k, (x, y, z) in enumerate(grains)]
    head = ['LIGGGHTS data: marker columns', '', f'{len(rows)} atoms', '3 atom types',
            '-0.16 0.16 xlo xhi', '-0.11 0.12 ylo yhi', '-0.01 0.51 zlo zhi', '', 'Atoms', '']
    path.parent.mkdir(parents=True)
    path.write_text('\n'.join(head + rows) + '\n')


@pytest.mark.slow
@pytest.mark.liggghts
def test_every_deck_variant_runs_on_liggghts_and_matches_dempaths_time_axis(
        liggghts: LiggghtsInstall, tmp_path: Path) -> None:
    """Each variant's pass runs on LIGGGHTS 3.8 (the files parse, the tine moves through the
    axis markers), the tool-speed variant drives the same 270 mm in 0.31 s / 1.5, and dempath's
    engine on the same bed records the same output times and picks the same marker grains."""
    bed = tmp_path / 'seed1' / 'bed.data'
    write_marker_bed(bed)
    for variant in sorted(VARIANTS):
        run = run_deck(1, variant, tmp_path, nprocs=1)
        frames = deck_frames(run)
        speed = VARIANTS[variant][0].get('tool_speed.speed_scale', 1.0)
        assert frames.times[-1] == pytest.approx(0.31 / speed, abs=0.01), variant
        stats = deck_stats(frames, 0.0045)
        assert np.nanmax(stats.axis) > 0.02, variant  # the tine knocks the axis columns over
        assert np.nanmax(stats.lateral) < 0.002, variant  # and passes the side ones
    dem = same_bed_run(bed, same_physics(scene_for('tool_speed')))
    lig = deck_frames(tmp_path / 'seed1' / 'tool_speed')
    np.testing.assert_allclose(dem.times, lig.times, atol=1e-9)
    assert np.nanmax(deck_stats(dem, 0.0045).axis) > 0.02
    assert deck_stats(dem, 0.0045).markers == deck_stats(lig, 0.0045).markers
