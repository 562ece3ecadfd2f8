"""LIGGGHTS backend: install/run errors, deck building blocks, dump readers, a tiny scene."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dempath.dumpio import frames_by_id, read_dump, read_print
from dempath_sim.engine.materials import Interaction, Material
from dempath_sim.engine.params import SimParams
from dempath_sim.liggghts import commands as cmd
from dempath_sim.liggghts.errors import DumpError, LiggghtsNotFoundError, LiggghtsRunError
from dempath_sim.liggghts.fill_deck import fill_plan, layer_templates, primes_from
from dempath_sim.liggghts.install import LiggghtsInstall, ensure_liggghts, find_liggghts
from dempath_sim.liggghts.runner import run_deck
from dempath_sim.liggghts.tool_deck import velocity_expression
from dempath_sim.runs.identity import run_identity
from dempath_sim.scene import bundled_scene
from dempath_sim.scene.profiles import SpeedProfile, ToolPath


def _params(rolling: float = 0.26, cohesion: float = 0.0) -> SimParams:
    sand = Material('sand', 1734.0, 1.7e6, 0.25)
    steel = Material('steel', 7800.0, 2.1e11, 0.3)
    pp = Interaction(0.3, 0.71, 0.59, rolling, cohesion)
    pw = Interaction(0.3, 0.40, 0.30, rolling, cohesion)
    return SimParams(materials=(sand, steel), interactions={(0, 0): pp, (0, 1): pw})


def test_missing_binary_names_it_and_the_fix() -> None:
    """An explicit binary that does not exist gives one error naming it and the apt command."""
    assert find_liggghts('/nonexistent/liggghts') is None
    with pytest.raises(LiggghtsNotFoundError, match=r'/nonexistent/liggghts: .*apt-get install'):
        ensure_liggghts('/nonexistent/liggghts', install=False)


def test_backend_checks_its_settings_and_honours_stop(tmp_path: Path) -> None:
    """Bad settings name the field; a stop set before the run stops it before any I/O."""
    from threading import Event

    from dempath_sim.errors import RunStoppedError
    from dempath_sim.liggghts import LiggghtsBackend
    from dempath_sim.runs import RunOptions

    with pytest.raises(ValueError, match=r'LiggghtsBackend\.fill: .*got \'poured\''):
        LiggghtsBackend(tmp_path, fill='poured')
    with pytest.raises(ValueError, match=r'LiggghtsBackend\.nprocs: must be >= 1, got 0'):
        LiggghtsBackend(tmp_path, nprocs=0)
    stop = Event()
    stop.set()
    backend = LiggghtsBackend(tmp_path / 'run')
    with pytest.raises(RunStoppedError, match='before the fill'):
        backend.run(bundled_scene('tiny'), RunOptions(stop=stop))
    assert not (tmp_path / 'run').exists()


def test_failing_deck_gives_one_line_with_the_log(liggghts: LiggghtsInstall,
                                                  tmp_path: Path) -> None:
    """A bad command stops with LIGGGHTS' error text and the path of the log file."""
    deck = tmp_path / 'in.bad'
    deck.write_text('units si\nno_such_command 1 2\n')
    with pytest.raises(LiggghtsRunError) as info:
        run_deck(deck, install=liggghts)
    text = str(info.value)
    assert '\n' not in text
    assert 'Unknown command: no_such_command' in text
    log = Path(text.rsplit('(log ', 1)[1].rstrip(')'))
    assert log.is_file() and 'no_such_command' in log.read_text(errors='replace')


def test_materials_map_to_per_type_properties() -> None:
    """Material i -> type i+1; pair matrices row-major; static friction by default."""
    lines = cmd.materials(_params())
    assert lines[0].endswith('youngsModulus peratomtype 1700000 210000000000')
    assert lines[3].endswith('coefficientFriction peratomtypepair 2 0.71 0.4 0.4 0')
    assert cmd.materials(_params(), 'dynamic')[3].endswith('peratomtypepair 2 0.59 0.3 0.3 0')
    assert any('coefficientRollingFriction' in x for x in lines)
    assert not any('cohesionEnergyDensity' in x for x in lines)


def test_contact_model_switches_follow_the_effects() -> None:
    """Rolling resistance and cohesion add epsd2 / sjkr exactly when a coefficient is set."""
    assert cmd.contact_model(_params(0.0)) == 'model hertz tangential history'
    assert cmd.contact_model(_params(0.26, 500.0)) == (
        'model hertz tangential history cohesion sjkr rolling_friction epsd2')
    assert cmd.needs_soft(_params())


def test_velocity_expression_matches_the_profile() -> None:
    """The LIGGGHTS speed expression equals SpeedProfile.velocity at every phase."""
    profile = SpeedProfile.from_distances(1.0, 0.1, 0.6, 0.1)
    path = ToolPath(profile, (0.0, -0.1, 0.05), offset_m=0.02)
    expr = velocity_expression(path)
    for t in np.linspace(0.0, profile.total_time_s - path.start_time_s - 1e-6, 57):
        got = eval(expr.replace('v_t', repr(float(t))))
        assert got == pytest.approx(float(profile.velocity(t + path.start_time_s)), abs=1e-9)


def test_uniform_layer_becomes_equal_number_bins() -> None:
    """A uniform +-10 % layer maps to 5 templates with mass fractions ~ d^3 summing to 1."""
    scene = bundled_scene('tiny')
    d, w = layer_templates(scene.layers[0], 1.0)
    assert len(d) == 5 and sum(w) == pytest.approx(1.0)
    assert min(d) > 0.9 * scene.layers[0].diameter_m and max(d) < 1.1 * scene.layers[0].diameter_m
    assert np.allclose(np.asarray(w) / np.asarray(d) ** 3, w[0] / d[0] ** 3)
    plan = fill_plan(scene, 1.0, 0.6)
    volume = plan.counts[0] * np.pi / 6 * np.mean(np.asarray(d) ** 3)
    bed = scene.bin.width_x_m * scene.bin.length_z_m * scene.layers[0].thickness_m
    assert volume == pytest.approx(0.6 * bed, rel=0.01)


def test_seeds_are_distinct_primes() -> None:
    """LIGGGHTS seeds are primes above 10000, distinct, and differ between packing seeds."""
    a, b = primes_from(1, 6), primes_from(2, 6)
    assert len(set(a)) == 6 and min(a) > 10000 and not set(a) & set(b)
    assert all(all(p % k for k in range(2, int(p ** 0.5) + 1)) for p in a)


def _write_dump(path: Path) -> None:
    frame = ('ITEM: TIMESTEP\n{step}\nITEM: NUMBER OF ATOMS\n{n}\nITEM: BOX BOUNDS ff ff ff\n'
             '0 1\n0 1\n0 1\nITEM: ATOMS id x y z\n{rows}')
    path.write_text(frame.format(step=0, n=2, rows='7 0.1 0.2 0.3\n3 1 2 3\n')
                    + frame.format(step=50, n=1, rows='3 4 5 6\n'))


def test_dump_reader_keeps_ids_and_marks_lost_particles_nan(tmp_path: Path) -> None:
    """Frames are laid out by id; an id missing from a frame is NaN there."""
    _write_dump(tmp_path / 'd.dump')
    frames = read_dump(tmp_path / 'd.dump')
    assert [f.step for f in frames] == [0, 50]
    got = frames_by_id(frames, np.array([3, 7]), ('x', 'y', 'z'))
    assert np.array_equal(got[0], [[1, 2, 3], [0.1, 0.2, 0.3]])
    assert np.array_equal(got[1, 0], [4, 5, 6]) and np.isnan(got[1, 1]).all()


def test_truncated_dump_and_bad_print_name_the_file(tmp_path: Path) -> None:
    """A truncated dump or a ragged print file raises DumpError naming the file."""
    path = tmp_path / 'd.dump'
    _write_dump(path)
    path.write_text(path.read_text()[:-8])
    with pytest.raises(DumpError, match=r'd\.dump: frame at step 50: 0 of 1 atom rows'):
        read_dump(path)
    bad = tmp_path / 'p.txt'
    bad.write_text('# head\n1 2 3\n4 5\n')
    with pytest.raises(DumpError, match=r'p\.txt: row 2 has 2 columns, expected 3'):
        read_print(bad, 3)


@pytest.mark.liggghts
def test_tiny_scene_runs_end_to_end_on_liggghts(liggghts: LiggghtsInstall, tmp_path: Path) -> None:
    """The tiny scene fills, drives the tool its travel and returns 15 tracked markers."""
    from dempath_sim.liggghts import LiggghtsBackend

    scene = bundled_scene('tiny')
    result = LiggghtsBackend(tmp_path).run(scene)
    assert len(result.marker_numbers) == 15
    dt = result.meta['dt_s']  # dempath's time step, so outputs fall where dempath's do
    step = round(scene.output.interval_s / dt) * dt
    assert np.allclose(np.diff(result.times), step)
    assert abs(step - scene.output.interval_s) <= dt / 2
    travel = result.tool_position[-1, 2] - result.tool_position[0, 2]
    assert travel == pytest.approx(scene.tool.travel_m, abs=2e-3)
    assert np.ptp(result.tool_position[:, :2], axis=0).max() < 1e-9
    assert np.nanmean(result.draft_force()[1:]) > 0.0  # soil resists the travel
    fill = result.meta['fill']
    assert 0.4 < fill['solid_fraction'] < 0.7
    assert abs(fill['surface_height_m']) < 0.03
    identity = run_identity(scene).as_meta()  # a native run's identity; the run id names the
    del identity['run_id']  # engine ('<scene>-s<seed>-liggghts')
    assert {k: result.meta[k] for k in identity} == identity
    assert result.meta['run_id'] == f'tiny-s{scene.seed}-liggghts'


@pytest.mark.liggghts
def test_liggghts_accepts_the_contact_model_with_every_effect(liggghts: LiggghtsInstall,
                                                              tmp_path: Path) -> None:
    """Two grains and a wall with rolling resistance and cohesion both on: LIGGGHTS 3.8 reads
    the pair style and the wall fix as written (it rejects the keywords in another order)."""
    params = _params(0.26, 1e5)
    words = cmd.contact_model(params)
    deck = tmp_path / 'in.effects'
    deck.write_text('\n'.join([
        *cmd.header((-0.05, -0.05, -0.05), (0.05, 0.05, 0.05), 2, 0.002, cmd.needs_soft(params)),
        'hard_particles yes', *cmd.materials(params), *cmd.pair_style(params),
        f'fix floor all wall/gran {words} primitive type 2 yplane -0.01',
        'timestep 1e-6', 'fix integr all nve/sphere', 'fix grav all gravity 9.81 vector 0 -1 0',
        'create_atoms 1 single 0 0 0 units box', 'create_atoms 1 single 0.0039 0 0 units box',
        'set group all diameter 0.004 density 1734', 'run 20',
        'write_dump all custom out.dump id x y z', '']))
    run_deck(deck, install=liggghts)
    frame = read_dump(tmp_path / 'out.dump')[0]
    assert frame.step == 20 and frame.data.shape == (2, 4)


@pytest.mark.liggghts
def test_packing_data_file_round_trips_through_liggghts(liggghts: LiggghtsInstall,
                                                        tmp_path: Path) -> None:
    """A dempath packing written as a data file is read by LIGGGHTS with ids, sizes, positions."""
    from dempath_sim.liggghts.fill_deck import write_data

    rng = np.random.default_rng(3)
    ids = np.arange(1, 11, dtype=np.int64) * 7
    pos = rng.uniform(0.0, 0.1, (10, 3))
    radii = rng.uniform(0.001, 0.002, 10)
    vel = rng.normal(0.0, 0.1, (10, 3))
    write_data(str(tmp_path / 'bed.data'), ids, pos, vel, np.zeros((10, 3)), radii, 1734.0, 3,
               ((-0.1, -0.1, -0.1), (0.2, 0.2, 0.2)))
    deck = tmp_path / 'in.read'
    deck.write_text('\n'.join([
        'atom_style granular', 'atom_modify map array', 'boundary f f f', 'newton off',
        'units si', 'read_data bed.data',
        'write_dump all custom out.dump id x y z vx vy vz radius mass', '']))
    run_deck(deck, install=liggghts)
    frame = read_dump(tmp_path / 'out.dump')[0]
    got = frames_by_id([frame], ids, ('x', 'y', 'z', 'vx', 'vy', 'vz', 'radius', 'mass'))[0]
    assert np.allclose(got[:, :3], pos, atol=1e-8)
    assert np.allclose(got[:, 3:6], vel, atol=1e-6)
    assert np.allclose(got[:, 6], radii, rtol=1e-6)
    assert np.allclose(got[:, 7], 1734.0 * 4 / 3 * np.pi * radii ** 3, rtol=1e-5)


def test_cli_bad_input_prints_one_error_line(capsys: pytest.CaptureFixture[str]) -> None:
    """``dempath liggghts`` and ``dempath validate`` reject bad input with one line, status 1."""
    from dempath_sim.liggghts.cli import liggghts_main
    from dempath_sim.validation.cli import validate_main

    assert liggghts_main(['/nonexistent/scene.yaml']) == 1
    assert liggghts_main(['builtin:tiny', '--np', '0']) == 1
    assert validate_main(['--seeds', '1']) == 1
    lines = capsys.readouterr().err.strip().splitlines()
    assert lines == ['error: /nonexistent/scene.yaml: cannot read scene file (No such file or '
                     'directory)', 'error: --np: must be >= 1, got 0',
                     'error: --seeds: need at least 2 for a spread, got 1']
