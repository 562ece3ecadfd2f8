"""``dempath simulate`` and ``dempath effects``: run a scene offline, list the physical effects.

``dempath simulate SCENE [--out DIR] [--seed N] [--effect EFFECT.PARAM=VALUE ...] [--off EFFECT]``
fills (or reads the cached packing), drives the tool with a progress bar showing simulated time
and the real-time factor, and writes ``model.csv`` (t,id,marker,x,y,z), ``markers.csv``
(t,marker,x,y,z), ``tool.csv``, ``result.npz`` and ``summary.json`` to DIR; with ``--vtk`` also
the bed snapshots (with radii) and the tool per snapshot as VTK for ParaView (DIR/vtk, see
:mod:`dempath_sim.runs.vtk`). SCENE is a scene file or the name of a shipped scene (``tiny``,
``reduced_1ms``, ... or ``builtin:tiny``).

``dempath effects [SCENE] [--json]`` prints every effect with its parameters, units, ranges and
defaults, and, with a scene, whether each is on and the scene's values.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from dempath.errors import DempathError
from dempath_sim.effects import effect_table
from dempath_sim.runs import Progress
from dempath_sim.runs.folder import SimulateRequest, run_to_folder, write_run_folder
from dempath_sim.scene import SceneError, SceneSpec, parse_overrides, resolve_scene

__all__ = ['effects_main', 'simulate_main', 'write_run_folder']


def _error_line(scene: str, err: Exception) -> str:
    """``error: <input>: <problem>``; scene errors already start with their file."""
    text = ' '.join(str(err).split())
    return f'error: {text}' if isinstance(err, SceneError) else f'error: {scene}: {text}'


def _simulate_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog='dempath simulate', description=__doc__.split('\n\n')[1])
    p.add_argument('scene', help='scene file or shipped scene name')
    p.add_argument('--out', type=Path, help='output directory (default: ./sim_<run id>)')
    p.add_argument('--seed', type=int, help='packing seed (default: the scene seed)')
    p.add_argument('--effect', action='append', default=[], metavar='EFFECT.PARAM=VALUE',
                   help='set an effect parameter (switches the effect on); repeatable')
    p.add_argument('--off', action='append', default=[], metavar='EFFECT',
                   help='switch an effect off; repeatable')
    p.add_argument('--on', action='append', default=[], metavar='EFFECT',
                   help='switch an effect on with its scene/default values; repeatable')
    p.add_argument('--cache-dir', type=Path, help='packing cache directory')
    p.add_argument('--vtk', action='store_true',
                   help='also write the bed snapshots (with radii) and the tool per snapshot as '
                        'VTK for ParaView (DIR/vtk/bed.pvd, tool.pvd)')
    p.add_argument('--quiet', action='store_true', help='no progress bar')
    return p


def _progress_bar(quiet: bool) -> tuple[Any, Any]:
    """A rich progress bar and its update callback (or nothing when quiet)."""
    if quiet:
        return None, None
    from rich.progress import BarColumn, TextColumn, TimeElapsedColumn
    from rich.progress import Progress as Bar

    bar = Bar(TextColumn('{task.description:<6}'), BarColumn(),
              TextColumn('{task.fields[sim]}'), TextColumn('RTF {task.fields[rtf]}'),
              TimeElapsedColumn(), transient=False)
    tasks: dict[str, Any] = {}

    def update(p: Progress) -> None:
        if p.phase not in tasks:
            tasks[p.phase] = bar.add_task(p.phase, total=p.end_time_s, sim='', rtf='')
        bar.update(tasks[p.phase], completed=min(p.sim_time_s, p.end_time_s),
                   sim=f'{p.sim_time_s:.3f}/{p.end_time_s:.3f} s',
                   rtf=f'{p.real_time_factor:.3g}')

    return bar, update


def simulate_main(argv: list[str]) -> int:
    """``dempath simulate SCENE --out DIR``: run a scene offline with a progress bar."""
    args = _simulate_parser().parse_args(argv)
    try:
        scene = resolve_scene(args.scene).with_overrides(
            parse_overrides(args.effect), off=args.off, on=args.on, seed=args.seed)
        request = SimulateRequest(scene, args.out, args.cache_dir, args.vtk)
        bar, update = _progress_bar(args.quiet)
        if bar is not None:
            with bar:
                outcome = run_to_folder(request, update)
        else:
            outcome = run_to_folder(request)
        if outcome.vtk is not None:
            vtk = outcome.vtk
            print(f'VTK: {vtk.bed_series} and {vtk.tool_series} ({len(vtk.bed_files)} frames)')
    except (DempathError, OSError) as err:
        print(_error_line(args.scene, err), file=sys.stderr)
        return 1
    result, summary, out = outcome.result, outcome.summary, outcome.folder
    fill = result.meta['fill']
    print(f"{result.meta['run_id']}: {result.meta['n_particles']} particles, bulk density "
          f"{fill['bulk_density_kg_m3']:.0f} kg/m^3 (solid fraction {fill['solid_fraction']:.3f})"
          f", {len(result.times)} frames, max draft {summary['max_draft_force_n']:.1f} N, "
          f'outputs in {out}')
    return 0


def effect_rows(scene: SceneSpec | None) -> list[dict[str, Any]]:
    """One row per effect parameter: effect, on, parameter, unit, low, high, default, value."""
    return effect_table(scene.effects if scene is not None else None)


def effects_main(argv: list[str]) -> int:
    """``dempath effects [SCENE]``: the physical effects, their parameters, units and ranges."""
    p = argparse.ArgumentParser(prog='dempath effects', description='List physical effects.')
    p.add_argument('scene', nargs='?', help='scene file or shipped scene name')
    p.add_argument('--json', action='store_true', help='print JSON rows instead of a table')
    args = p.parse_args(argv)
    try:
        scene = resolve_scene(args.scene) if args.scene else None
    except DempathError as err:
        print(_error_line(args.scene, err), file=sys.stderr)
        return 1
    rows = effect_rows(scene)
    if args.json:
        print(json.dumps(rows, indent=2))
        return 0
    from rich.console import Console
    from rich.table import Table

    title = f'effects in {scene.name}' if scene else 'effects (defaults)'
    table = Table(title=title)
    for col in ('effect', 'on', 'parameter', 'unit', 'range', 'default', 'value'):
        table.add_column(col)
    for r in rows:
        on = ('on' if r['enabled'] else 'off') + ('' if r['switchable'] else ' (fixed)')
        table.add_row(r['effect'], on, r['parameter'], r['unit'], f"{r['low']:g}..{r['high']:g}",
                      f"{r['default']:g}", f"{r['value']:g}")
    console = Console()
    if not console.is_terminal:  # pipes and files get the whole table, not 80 columns
        console = Console(width=160)
    console.print(table)
    return 0
