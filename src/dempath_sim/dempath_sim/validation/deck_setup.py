"""Cross-engine check against a bin dempath did not build: the hand-written leaning-tine deck.

``data/decks/leaning_tine`` is a LIGGGHTS 3.8 deck written by hand the way LIGGGHTS users set a
bin up (random ``insert/pack``, the grains overlapping the tine deleted, 0.4 s settle with the
tine in place, ``write_data``, then ``read_data``, a 0.06 s re-settle with the tine in place and
the pass). This module runs it (`run_deck`), runs dempath's engine from the deck's own settled
bed with the tine in place and the same re-settle (`same_bed_run`), and reduces every run, the
deck's or dempath's, to the same figures with the same rules (`deck_stats`), so that
``bench/cross_engine_setup.py`` can compare dempath's set-ups with the deck's.

Markers: at each grid point (X = 0 and +-50 mm beside the tine, Z = 200-340 mm every 35 mm)
the surface grain nearest to it when the tine starts (centre within 12 mm horizontally and
within one mean radius of the highest such grain). Figures per run: the mean displacement
|x(t) - x(0)| of the axis markers and of the ten side markers at every output, the side
markers' mean outward motion sign(x0) (x(t) - x0) (what cohesion cuts) and the mean draft
-F_z over the outputs after t = 0.
"""

from __future__ import annotations

import subprocess
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from dempath_sim.engine import Engine, SimParams, SimState, ToolPose, TriangleMesh
from dempath_sim.runs import PARTICLES, TOOL, SimResult, bin_walls, build_params
from dempath_sim.scene import SceneSpec, ToolPath, load_scene

F64 = NDArray[np.float64]
DECKS_DIR = Path(__file__).resolve().parents[1] / 'data' / 'decks'
RESETTLE_S = 0.06  # the decks' re-settle with the tine in place (in.pass)
DECK_DT = 5e-5  # s, the decks' time step
DECK_SKIN_M = 0.003  # m, the decks' neighbour skin (header of in.settle / in.pass)
OUTPUT_STEPS = 200  # the decks' dump and print interval (0.01 s)
SIDE_X = 0.05  # m, the side markers' distance from the tine's axis
NEAR_M = 0.012  # m, horizontal reach of a marker's grid point


@dataclass(frozen=True)
class Deck:
    """One hand-written deck: its folder, its scene files and its marker rules.

    Attributes:
        name: the folder under ``data/decks``.
        marker_z: Z of the marker grid points [m] (X = 0 and +-SIDE_X).
        top_zone: the deck's 'top' group (X, Y, Z ranges [m]) dumped every output.
        mean_r: mean grain radius [m] (marker rule).
        scenes: set-up name -> scene file of the folder (``dempath`` is the deck's input
            numbers; others as the deck's README says).
    """

    name: str
    marker_z: tuple[float, ...]
    top_zone: tuple[tuple[float, float], ...]
    mean_r: float
    scenes: dict[str, str]

    @property
    def folder(self) -> Path:
        """The deck's folder."""
        return DECKS_DIR / self.name

    def scene_file(self, setup: str = 'dempath') -> Path:
        """The scene file of a dempath set-up of the deck's bin."""
        return self.folder / self.scenes[setup]


LEANING_TINE = Deck('leaning_tine', (0.200, 0.235, 0.270, 0.305, 0.340),
                    ((-0.09, 0.09), (-0.03, 0.06), (0.17, 0.37)), 0.0045,
                    {'dempath': 'leaning_tine.yaml',
                     'dempath_measured': 'leaning_tine_measured.yaml',
                     'dempath_poured': 'leaning_tine_poured.yaml'})
RAKED_TINE = Deck('raked_tine', (0.15, 0.20, 0.25, 0.30, 0.35),
                  ((-0.09, 0.09), (-0.03, 0.06), (0.12, 0.38)), 0.00375,
                  {'dempath': 'raked_tine.yaml', 'dempath_poured': 'raked_tine.yaml'})
DECKS = {d.name: d for d in (LEANING_TINE, RAKED_TINE)}
DECK_DIR = LEANING_TINE.folder
SCENE_FILE = LEANING_TINE.scene_file()
MEASURED_SCENE_FILE = LEANING_TINE.scene_file('dempath_measured')  # the deck's bed as measured
POURED_SCENE_FILE = LEANING_TINE.scene_file('dempath_poured')  # the same, poured around the tine
MARKER_Z = LEANING_TINE.marker_z
TOP_ZONE = LEANING_TINE.top_zone
# Scene overrides of the deck's physics variants (in.pass -var variant, physics_<variant>.in):
# rolling resistance and cohesion between grains only, as the deck's wall and tine fixes leave
# them out; the other candidates of the effects library at the library's upper strength (x1.5,
# Young's modulus x3). LIGGGHTS has one Coulomb coefficient per pair: static = dynamic.
VARIANTS: dict[str, tuple[dict[str, float], tuple[str, ...]]] = {
    'base': ({}, ()),
    'rolling': ({'rolling_resistance.boundary_fraction': 0.0}, ('rolling_resistance',)),
    'cohesion': ({'cohesion.boundary_fraction': 0.0}, ('cohesion',)),
    'tool_friction': ({'tool_friction.static_friction': 0.60,
                       'tool_friction.dynamic_friction': 0.60}, ()),
    'particle_friction': ({'particle_friction.static_friction': 1.065,
                           'particle_friction.dynamic_friction': 1.065}, ()),
    'youngs_modulus': ({'youngs_modulus.youngs_modulus_pa': 5.1e6}, ()),
    'restitution': ({'restitution.particle_particle': 0.45,
                     'restitution.particle_boundary': 0.45}, ()),
    'tool_speed': ({'tool_speed.speed_scale': 1.5}, ()),
}


@dataclass(frozen=True)
class Frames:
    """Positions of the grains near the surface around the marker spots, every output.

    Attributes:
        times: (nt,) s since the tine started.
        ids: (n,) grain ids.
        positions: (nt, n, 3) m; NaN where a grain is missing.
        force: (nt, 3) force of the grains on the tine [N].
    """

    times: F64
    ids: NDArray[np.int64]
    positions: F64
    force: F64


@dataclass(frozen=True)
class DeckStats:
    """Figures of one run (see the module docstring): times (nt,) s; axis, lateral and
    outward (nt,) m; draft N; the markers' grain ids per group."""

    times: F64
    axis: F64
    lateral: F64
    outward: F64
    draft: float
    markers: dict[str, list[int]]


def scene_for(variant: str, seed: int = 1, scene_file: Path = SCENE_FILE) -> SceneSpec:
    """The deck's bin as a dempath scene (``leaning_tine.yaml``, or ``scene_file``) with the
    variant's physics and the given seed."""
    values, on = VARIANTS[variant]
    return load_scene(scene_file).with_overrides(values, on=on, seed=seed)


def run_deck(seed: int, variant: str, workdir: Path, nprocs: int = 2,
             deck: Deck = LEANING_TINE) -> Path:
    """Run the deck (``run.sh``) for one packing seed and variant; returns the run directory.

    The settled bed of a seed (``workdir/seed<k>/bed.data``) is made once and shared by the
    variants. Raises subprocess.CalledProcessError when LIGGGHTS fails.
    """
    subprocess.run(['sh', str(deck.folder / 'run.sh'), str(seed), variant, str(workdir),
                    str(nprocs)], check=True, capture_output=True)
    return workdir / f'seed{seed}' / variant


def read_dump(path: Path) -> list[tuple[int, dict[str, F64]]]:
    """Frames (step, column -> values) of a LIGGGHTS ``dump custom`` text file."""
    lines, frames, k = path.read_text().splitlines(), [], 0
    while k + 9 <= len(lines):
        n = int(lines[k + 3])
        cols = lines[k + 8].split()[2:]
        data = np.loadtxt(lines[k + 9:k + 9 + n], ndmin=2)
        frames.append((int(lines[k + 1]), {c: data[:, j] for j, c in enumerate(cols)}))
        k += 9 + n
    return frames


def read_data(path: Path) -> dict[str, F64]:
    """Atoms and Velocities of a LIGGGHTS ``write_data`` file of ``atom_style granular``:
    id, type, diameter [m], density [kg/m^3], x y z [m]; vx vy vz [m/s], wx wy wz [rad/s]."""
    lines = path.read_text().splitlines()
    n = int(next(line.split()[0] for line in lines if line.strip().endswith('atoms')))
    at = lines.index('Atoms') + 2 if 'Atoms' in lines else lines.index('Atoms # granular') + 2
    atoms = np.loadtxt(lines[at:at + n], ndmin=2)
    vel: F64 = np.zeros((n, 7))
    if 'Velocities' in lines:
        v0 = lines.index('Velocities') + 2
        vel = np.loadtxt(lines[v0:v0 + n], ndmin=2)
    order = np.argsort(atoms[:, 0])
    vorder = np.argsort(vel[:, 0]) if 'Velocities' in lines else order
    return {'ids': atoms[order, 0], 'radii': atoms[order, 2] / 2, 'density': atoms[order, 3],
            'positions': atoms[order, 4:7], 'velocities': vel[vorder, 1:4],
            'omegas': vel[vorder, 4:7]}


def deck_frames(run: Path) -> Frames:
    """The deck run's ``top.dump`` frames and ``tine_force.txt`` on one time axis."""
    dumps = read_dump(run / 'top.dump')
    first = dumps[0][1]
    ids = np.asarray(first['id'], np.int64)
    pos = np.full((len(dumps), len(ids), 3), np.nan)
    for f, (_, cols) in enumerate(dumps):
        where = {int(i): k for k, i in enumerate(cols['id'])}
        rows = [(m, where[int(i)]) for m, i in enumerate(ids) if int(i) in where]
        m_idx, k_idx = (np.array(x, np.int64) for x in zip(*rows, strict=True))
        pos[f, m_idx] = np.stack([cols['x'][k_idx], cols['y'][k_idx], cols['z'][k_idx]], 1)
    start = dumps[0][0]
    times = np.array([(s - start) for s, _ in dumps], float) * DECK_DT
    printed = np.loadtxt(run / 'tine_force.txt', skiprows=1, ndmin=2)
    force = np.zeros((len(times), 3))
    for f, t in enumerate(times):  # the print starts one interval after the dump
        hit = np.flatnonzero(np.isclose(printed[:, 0], t, atol=1e-6))
        if len(hit):
            force[f] = printed[hit[0], 1:4]
    return Frames(times, ids, pos, force)


def pick_markers(ids: NDArray[np.int64], positions: F64, mean_r: float,
                 marker_z: tuple[float, ...] = MARKER_Z) -> dict[str, list[int]]:
    """Marker indices into ``ids`` per group ('axis', 'left', 'right'), from the start positions
    (n, 3) [m], at the grid points ``marker_z`` (see the module docstring)."""
    out: dict[str, list[int]] = {'axis': [], 'left': [], 'right': []}
    for group, gx in (('axis', 0.0), ('left', -SIDE_X), ('right', SIDE_X)):
        for gz in marker_z:
            h = np.hypot(positions[:, 0] - gx, positions[:, 2] - gz)
            near = np.flatnonzero(h < NEAR_M)
            top = positions[near, 1].max()
            ok = near[positions[near, 1] > top - mean_r]
            out[group].append(int(ok[np.argmin(h[ok])]))
    return out


def deck_stats(frames: Frames, mean_r: float, marker_z: tuple[float, ...] = MARKER_Z) -> DeckStats:
    """The figures of one run from its frames (markers picked at t = 0 at ``marker_z``)."""
    idx = pick_markers(frames.ids, frames.positions[0], mean_r, marker_z)
    p = frames.positions
    disp = np.linalg.norm(p - p[:1], axis=2)
    side = idx['left'] + idx['right']
    sign = np.array([-1.0] * len(idx['left']) + [1.0] * len(idx['right']))
    outward = np.nanmean(sign * (p[:, side, 0] - p[:1, side, 0]), axis=1)
    draft = float(-np.mean(frames.force[1:, 2]))
    markers = {g: [int(frames.ids[i]) for i in v] for g, v in idx.items()}
    return DeckStats(frames.times, np.nanmean(disp[:, idx['axis']], axis=1),
                     np.nanmean(disp[:, side], axis=1), outward, draft, markers)


def result_frames(result: SimResult, top_zone: tuple[tuple[float, float], ...] = TOP_ZONE
                  ) -> Frames:
    """Frames of a dempath run (`run_scene`) whose full-bed snapshots fall on every output:
    the grains of the deck's surface zone (``top_zone``) at t = 0, and the tool force."""
    if len(result.snapshot_times) != len(result.times):
        msg = 'result_frames: the run needs output.snapshot_interval_s = output.interval_s'
        raise ValueError(msg)
    snap = np.asarray(result.snapshot_positions, np.float64)
    zone = _in_top_zone(snap[0], top_zone)
    return Frames(result.times, result.snapshot_ids[zone], snap[:, zone], result.tool_force)


def _in_top_zone(positions: F64, top_zone: tuple[tuple[float, float], ...] = TOP_ZONE
                 ) -> NDArray[np.bool_]:
    keep = np.ones(len(positions), bool)
    for axis, (lo, hi) in enumerate(top_zone):
        keep &= (positions[:, axis] > lo) & (positions[:, axis] < hi)
    return keep


def deck_params(scene: SceneSpec, radii: F64) -> SimParams:
    """The scene's engine parameters with the deck's neighbour skin (``neighbor 0.003 bin``).

    With LIGGGHTS' contact forms a pair's springs outlive a separation until the next
    neighbour-list build (`engine.pair_forces`), and the builds come when a grain has moved half
    the skin: the same skin gives the same lifetime of those springs as the deck's.
    """
    params = build_params(scene, scene.physics_model())
    return replace(params, skin=DECK_SKIN_M / float(np.min(radii)))


def same_bed_run(bed: Path, scene: SceneSpec, resettle_s: float = RESETTLE_S,
                 max_frames: int | None = None,
                 top_zone: tuple[tuple[float, float], ...] = TOP_ZONE) -> Frames:
    """dempath's engine from the deck's settled bed (``bed.data``): the tine in place, a re-settle
    of ``resettle_s`` with the scene's physics (contacts start with no history, as the deck's
    ``read_data``), then the scene's pass, recorded every OUTPUT_STEPS steps (the first
    ``max_frames`` outputs after the start only, if given: a shortened pass for quick checks)."""
    bed_data = read_data(bed)
    params = deck_params(scene, bed_data['radii'])
    state = SimState.from_spheres(bed_data['positions'], bed_data['radii'], PARTICLES, params,
                                  velocities=bed_data['velocities'],
                                  ids=bed_data['ids'].astype(np.int64))
    state.angular_velocities[:] = bed_data['omegas']
    tool = scene.tool
    start = (tool.x_m, -tool.depth_m + tool.settling_offset_m, tool.start_z_m)
    path = ToolPath(tool.profile.scaled(scene.physics_model().speed_scale), start,
                    tool.profile_offset_m)
    engine = Engine(params, bin_walls(scene),
                    TriangleMesh.from_stl(tool.mesh, material=TOOL, scale=tool.scale))
    still = ToolPose(np.array(start), np.zeros(3))
    engine.tool_pose = still
    engine.bind(state)
    dt = float(engine.dt or 0.0)
    state = engine.run(state, round(resettle_s / dt), lambda _t: still)
    state.time = 0.0
    zone = _in_top_zone(state.positions, top_zone)
    ids = state.ids[zone].copy()
    n_frames = int(np.ceil(path.time_to_travel(tool.travel_m) / (OUTPUT_STEPS * dt) - 1e-9))
    if max_frames is not None:
        n_frames = min(n_frames, max_frames)
    pos = np.full((n_frames + 1, len(ids), 3), np.nan)
    force = np.zeros((n_frames + 1, 3))
    for f in range(n_frames + 1):
        if f:
            state = engine.run(state, OUTPUT_STEPS,
                               lambda t: ToolPose(*path.pose_at(t)))
        order = np.argsort(state.ids)
        at = np.searchsorted(state.ids, ids, sorter=order).clip(0, state.n - 1)
        hit = state.ids[order[at]] == ids
        pos[f, hit] = state.positions[order[at][hit]]
        force[f] = engine.tool_force
    times = np.asarray(np.arange(n_frames + 1) * OUTPUT_STEPS * dt, np.float64)
    return Frames(times, ids, pos, force)
