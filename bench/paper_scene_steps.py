"""The paper's full-scale scene on dempath's engine: build it, step it, measure time and memory.

The paper's Rocky run (11,473,727 spheres, 3 s of simulated time) took 86 h on a workstation.
This benchmark builds ``builtin:paper_1ms`` (bin 1000 x 2400 x 1020 mm, 20 mm base, 4 mm top
layer, the shipped chisel at 184 mm, Table 6 physics) at full size and runs it for a few steps
with the tool moving at the profile's steady speed. A full pour-and-settle of 11 M spheres is
hours here, so the bed is the scene's pour with its lattice closed up (spacing 0.998 diameters):
every sphere touches its six lattice neighbours, as many contacts per sphere as a settled bed
has. Reports the particle count, seconds per step (after the first step, which builds the
neighbour list), the peak resident memory of the process, and what a 3 s run of the scene would
take on this machine at that rate. Last line: one JSON object.

    .venv/bin/python bench/paper_scene_steps.py [--steps 10] [--scene builtin:paper_1ms]
"""

from __future__ import annotations

import argparse
import json
import logging
import resource
import time

import numba
import numpy as np

from dempath_sim.engine import Engine, ToolPose
from dempath_sim.engine.mesh import TriangleMesh
from dempath_sim.runs.bed.measure import surface_height
from dempath_sim.runs.bed.placement import carve_tool_slot
from dempath_sim.runs.bed.pour import lattice_pour
from dempath_sim.runs.physics import TOOL, bin_walls, build_params
from dempath_sim.scene import load_scene

log = logging.getLogger('bench')
CLOSED_GAP = 0.998  # lattice spacing / diameter: neighbours overlap by 0.2 % of a diameter
PAPER_RUN_S = 3.0  # simulated time of the paper's Rocky run [s]
PAPER_ROCKY_HOURS = 86.0  # its wall time on the authors' workstation [h]


def peak_rss_bytes() -> int:
    """Peak resident memory of this process so far [bytes]."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


def main() -> None:
    """Build, step and print the JSON line."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--scene', default='builtin:paper_1ms')
    parser.add_argument('--steps', type=int, default=10)
    args = parser.parse_args()
    logging.basicConfig(level=logging.INFO, format='%(message)s')
    scene = load_scene(args.scene)
    model = scene.physics_model()
    params = build_params(scene, model)
    t0 = time.perf_counter()
    state = lattice_pour(scene, model, params, gap=CLOSED_GAP)
    state.velocities[:] = 0.0
    surface = surface_height(scene, state)
    mesh = TriangleMesh.from_stl(scene.tool.mesh, material=TOOL, scale=scene.tool.scale)
    start = (scene.tool.x_m, surface - scene.tool.depth_m, scene.tool.start_z_m)
    state = carve_tool_slot(state, mesh, start)
    build_s = time.perf_counter() - t0
    log.info('bed: %d spheres built in %.1f s, surface at %.3f m', state.n, build_s, surface)
    speed = scene.tool.profile.speed_m_s
    tip = np.asarray(start, dtype=float)

    def motion(t: float) -> ToolPose:
        return ToolPose(tip + np.array([0.0, 0.0, speed * t]), np.array([0.0, 0.0, speed]))

    engine = Engine(params, bin_walls(scene), mesh)
    engine.tool_pose = motion(0.0)
    t1 = time.perf_counter()
    state = engine.run(state, 1, motion)
    first_s = time.perf_counter() - t1
    log.info('first step (neighbour list build): %.1f s', first_s)
    t2 = time.perf_counter()
    state = engine.run(state, args.steps, motion)
    per_step = (time.perf_counter() - t2) / args.steps
    dt = float(engine.dt or 0.0)
    steps_3s = PAPER_RUN_S / dt
    hours_3s = steps_3s * per_step / 3600
    mem = engine.memory_bytes()
    result = {'scene': scene.name, 'particles': state.n, 'steps': args.steps,
              'threads': numba.get_num_threads(), 'dt_s': dt, 'build_s': build_s,
              'first_step_s': first_s, 'seconds_per_step': per_step,
              'particle_steps_per_s': state.n / per_step, 'pairs': mem['pairs'],
              'contacts': engine.n_contacts, 'engine_bytes': mem['particle_arrays'] + mem[
                  'pair_arrays'], 'peak_rss_bytes': peak_rss_bytes(),
              'steps_for_3s': steps_3s, 'hours_for_3s': hours_3s,
              'paper_rocky_hours_for_3s': PAPER_ROCKY_HOURS,
              'draft_force_n': float(engine.tool_force[2])}
    for key, value in result.items():
        log.info('%-26s %s', key, f'{value:.4g}' if isinstance(value, float) else value)
    print(json.dumps(result))


if __name__ == '__main__':
    main()
