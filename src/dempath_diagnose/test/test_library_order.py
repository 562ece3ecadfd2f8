"""The library starts its dearest runs first, so that no long run is left alone at the end."""

from __future__ import annotations

from dempath_diagnose.library.simulator import load_scene
from dempath_diagnose.library.store import LibrarySpec, LibraryTask, design
from dempath_sim.runs.portable import pack_scene


def test_run_cost_follows_simulated_time_over_the_stable_step() -> None:
    """Stiffer grains (a shorter Rayleigh step) and a slower tool (a longer pass) cost more;
    Young's modulus x3 costs sqrt(3) of the baseline; an effect that keeps the step costs
    the same."""
    scene = load_scene('builtin:tiny')
    spec = LibrarySpec(seeds=(1001,), candidates=('youngs_modulus', 'tool_speed', 'cohesion'))
    _, runs = design(scene, spec)
    portable = pack_scene(scene)
    cost = {r.label: LibraryTask(portable, r, spec, None).cost() for r in runs}
    base = cost['baseline']
    stiff = max(v for k, v in cost.items() if k.startswith('youngs_modulus'))
    soft = min(v for k, v in cost.items() if k.startswith('youngs_modulus'))
    slow = max(v for k, v in cost.items() if k.startswith('tool_speed'))
    assert abs(stiff / base - 3 ** 0.5) < 1e-6
    assert abs(soft / base - 0.3 ** 0.5) < 1e-6
    assert slow > base
    assert all(abs(v - base) < 1e-9 for k, v in cost.items() if k.startswith('cohesion'))
