"""``run_id`` (one id per run, different whenever anything that changes the run differs) and
the warnings a finished run carries when its answer cannot mean anything."""

from __future__ import annotations

import shutil
from dataclasses import replace
from pathlib import Path

from dempath_sim.runs import run_id
from dempath_sim.scene import bundled_scene


def test_run_id_changes_with_everything_that_changes_the_run(tmp_path: Path) -> None:
    """Time step, output cadence, depth, mesh bytes, packing file and bed physics each change
    the id (it used to hash the effects alone); the description and file path do not."""
    scene = bundled_scene('tiny')
    base = run_id(scene)
    mesh = tmp_path / 'tool.stl'
    shutil.copy(scene.tool.mesh, mesh)
    assert run_id(replace(scene, tool=replace(scene.tool, mesh=mesh))) == base
    assert run_id(replace(scene, description='another text', source='elsewhere.yaml')) == base
    changed = {
        'time step': replace(scene, sim=replace(scene.sim, time_step_s=1e-6)),
        'output interval': replace(scene, output=replace(scene.output, interval_s=0.005)),
        'depth': replace(scene, tool=replace(scene.tool, depth_m=scene.tool.depth_m + 0.01)),
        'bin': replace(scene, bin=replace(scene.bin, length_z_m=scene.bin.length_z_m + 0.1)),
        'packing': replace(scene, fill=replace(scene.fill, packing=mesh)),
        'seed': replace(scene, seed=scene.seed + 1),
        'effects': scene.with_overrides(off=['tool_friction']),
    }
    mesh.write_bytes(mesh.read_bytes() + b'\n')  # same name, other bytes
    changed['mesh bytes'] = replace(scene, tool=replace(scene.tool, mesh=mesh))
    ids = {label: run_id(s) for label, s in changed.items()}
    same = [label for label, rid in ids.items() if rid == base]
    assert not same, f'run_id ignores {same}'
    assert len(set(ids.values())) == len(ids)


def test_sparse_bed_and_untouched_tool_are_warned() -> None:
    """A 106-sphere bed (solid fraction 0.01) and a pass with 0 N draft each get a warning;
    a settled bed with a loaded tool gets none."""
    import numpy as np

    from dempath_sim.runs.bed import FillReport
    from dempath_sim.runs.native import run_warnings

    def report(n: int, fraction: float) -> FillReport:
        return FillReport(n, 2650 * fraction, fraction, -0.1, -0.2, None, True, 0.0, True,
                          'file:0', source='bed106.csv')

    loaded = np.zeros((20, 3))
    loaded[5:, 2] = -40.0
    assert run_warnings(loaded, report(45000, 0.6)) == []
    warnings = run_warnings(np.zeros((20, 3)), report(106, 0.012))
    assert len(warnings) == 2
    assert '106 particles at solid fraction 0.012' in warnings[0] and 'bed106.csv' in warnings[0]
    assert 'draft force is 0 N' in warnings[1]
