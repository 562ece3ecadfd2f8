"""Bad inputs tried as a careless user would (issue 27): each must be refused with one clear line,
or warned about in so many words, and leave nothing half-written that a reader accepts.

Every case runs the real command (``dempath ...`` in a subprocess) or, where a command would
take minutes of simulation, the library call under it. Outcomes:

- ``clear_error``: refused (exit 1 or 2) with an ``error:`` line and no traceback, or, for a
  case that is allowed to go on, finished with the expected warning in its output;
- ``traceback``: a Python traceback reached the user;
- ``silent_wrong``: an answer (exit 0) without the refusal or warning the input calls for;
- ``partial_outputs``: a refused case left its output folder behind (empty or half-written).

Usage: ``.venv/bin/python bench/bad_inputs.py [--work DIR] [--only NAME]``; the last line is one
JSON object with ``tried``, ``clear_error``, ``traceback``, ``silent_wrong``,
``partial_outputs`` and the outcome of each case.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
DEMPATH = str(Path(sys.executable).parent / 'dempath')
LIBRARY = ROOT / 'src/dempath_diagnose/dempath_diagnose/data/libraries/reduced_1ms_library.npz'
MEASURED = ROOT / 'bags' / 'field_twin_reduced_1ms.truth.csv'
ORIGIN = '0.05,0,0.45'  # the reduced scene's marker-grid centre on the surface [m]
CALIB_BAG = ROOT / 'bags' / 'calib_twin_small'
RENDER = ROOT / 'bags' / 'field_render_reduced_1ms'


@dataclass(frozen=True)
class Outcome:
    """What one case produced: exit code, the text the user saw, the folder it was told to
    write (None: none), and whether the input may be accepted with a warning."""

    code: int
    text: str
    out: Path | None = None
    warn: str = ''  # non-empty: exit 0 is right when this text is in the output


def run(argv: list[str], out: Path | None = None, warn: str = '', timeout: float = 600.0,
        ) -> Outcome:
    """``dempath ARGV`` in a subprocess."""
    done = subprocess.run([DEMPATH, *argv], capture_output=True, text=True, timeout=timeout,
                          check=False)
    return Outcome(done.returncode, done.stdout + done.stderr, out, warn)


def call(fn: Callable[[], str], warn: str = '') -> Outcome:
    """A library call: an exception of dempath's own is a refusal (its message the line)."""
    import traceback

    from dempath.errors import DempathError

    try:
        text = fn()
    except DempathError as err:
        return Outcome(1, f'error: {err}')
    except Exception:  # the bench reports a traceback instead of stopping
        return Outcome(1, traceback.format_exc())
    return Outcome(0, text, None, warn)


def classify(o: Outcome) -> tuple[str, bool]:
    """(clear_error | traceback | silent_wrong, partial output left behind)."""
    partial = False
    if o.out is not None and o.code != 0 and o.out.exists():
        from dempath.errors import OutputError
        from dempath.outputs import check_output_folder

        try:
            check_output_folder(o.out, 'summary.json')
            partial = True  # a refused run's folder that a reader would take
        except OutputError:
            partial = False
        partial = partial or not any(o.out.iterdir())
    if 'Traceback (most recent call last)' in o.text:
        return 'traceback', partial
    if o.code == 0:
        return ('clear_error' if o.warn and o.warn in o.text else 'silent_wrong'), partial
    lines = [line for line in o.text.strip().splitlines() if line.startswith('error')]
    return ('clear_error' if lines else 'traceback'), partial


def sim_folder(work: Path, name: str, damage: str) -> Path:
    """A ``dempath simulate``-shaped run folder left half-written in one of two ways."""
    import numpy as np

    from dempath.outputs import WRITING_MARKER
    from dempath_sim.cli import write_run_folder
    from dempath_sim.runs.results import SimResult

    n, nt = 15, 30
    rng = np.random.default_rng(3)
    pos = rng.uniform(-0.1, 0.1, (1, n, 3)) + np.cumsum(rng.normal(0, 1e-3, (nt, n, 3)), 0)
    result = SimResult(np.arange(nt) * 0.01, np.arange(n, dtype=np.int64), np.zeros(n, np.uint8),
                       np.arange(1, n + 1, dtype=np.int32), np.full(n, 0.004), pos,
                       np.zeros_like(pos), np.zeros((nt, 3)), np.zeros((nt, 3)),
                       np.zeros((nt, 3)), meta={'run_id': name, 'seed': 1})
    folder = work / name
    write_run_folder(result, folder)
    if damage == 'marker':
        (folder / WRITING_MARKER).write_text('1\n')
    else:
        text = (folder / 'model.csv').read_text()
        (folder / 'model.csv').write_text(text[:len(text) // 4])
    return folder


def damaged_calib_bag(work: Path, every: bool) -> Path:
    """The shipped calibration bag with one (or every) JPEG cut short."""
    sys.path.insert(0, str(ROOT / 'tests'))
    from test_calib_bad_frames import FRONT, damaged_copy

    dst = work / f'calib_damaged_{"all" if every else "one"}'
    shutil.rmtree(dst, ignore_errors=True)
    return damaged_copy(CALIB_BAG, dst, lambda topic, k: every or (topic == FRONT and k == 7))


def corrupt_packing_cache(work: Path) -> str:
    """A truncated entry in the packing cache: named, set aside, the bed found elsewhere."""
    import logging

    from dempath_sim.runs.bed import bundled_packing_dir, fill_bed, packing_key
    from dempath_sim.runs.physics import build_params
    from dempath_sim.scene import bundled_scene

    scene = bundled_scene('reduced_1ms')
    model = scene.physics_model()
    cache = work / 'packings'
    cache.mkdir(exist_ok=True)
    key = packing_key(scene, model)
    good = (bundled_packing_dir() / f'{key}.npz').read_bytes()
    (cache / f'{key}.npz').write_bytes(good[:1000])
    seen: list[str] = []
    handler = logging.Handler()
    handler.emit = lambda record: seen.append(record.getMessage())  # type: ignore[method-assign]
    logging.getLogger('dempath_sim.runs.bed').addHandler(handler)
    fill_bed(scene, model, build_params(scene, model), cache)
    return '\n'.join(seen)


def big_mesh() -> str:
    """A 1.2 M-triangle plate: binned in seconds, with a warning about its size."""
    import logging

    import numpy as np

    from dempath_sim.engine.mesh import TriangleMesh, build_triangle_grid

    u = np.linspace(0.0, 0.3, 776)
    x, z = np.meshgrid(u, u, indexing='ij')
    v = np.stack([x, np.zeros_like(x), z], axis=-1)
    a, b, c, d = v[:-1, :-1], v[1:, :-1], v[1:, 1:], v[:-1, 1:]
    tris = np.concatenate([np.stack([a, b, c], -2).reshape(-1, 3, 3),
                           np.stack([a, c, d], -2).reshape(-1, 3, 3)])
    seen: list[str] = []
    handler = logging.Handler()
    handler.emit = lambda record: seen.append(record.getMessage())  # type: ignore[method-assign]
    logging.getLogger('dempath_sim.engine.mesh').addHandler(handler)
    build_triangle_grid(TriangleMesh(tris, name='plate.stl'), 0.002)
    return '\n'.join(seen)


def resolution_mismatch(work: Path) -> str:
    """A 4:3 calibration for the 16:9 render: refused before the graph starts."""
    from dempath_bringup.nodes.graph import GraphSpec, fitted_calibration
    from dempath_calib.camera import StereoCalibration
    from dempath_twin.rig import paper_rig

    rig = paper_rig()
    cams = [type(c)(c.name, 1600, 1200, c.K, c.dist, c.R, c.t) for c in rig.cameras]
    calib = StereoCalibration(cams[0], cams[1], {}).save(work / 'calib_4x3.yaml')
    fitted_calibration(GraphSpec(RENDER, calib, 'tiny', work / 'run_bag', detect=True),
                       lambda text: None)
    return 'accepted'


def run_ids_differ() -> str:
    """Another time step gives another run id (it used to be the same)."""
    from dataclasses import replace

    from dempath_sim.runs import run_id
    from dempath_sim.scene import bundled_scene

    scene = bundled_scene('tiny')
    other = replace(scene, sim=replace(scene.sim, time_step_s=1e-6))
    return 'distinct run ids' if run_id(scene) != run_id(other) else 'same run id'


def sparse_packing(work: Path) -> Path:
    """The tiny scene on a 106-sphere packing file (a single loose layer)."""
    rows = [(x, -0.042, z, 0.012) for x in [-0.06 + 0.015 * i for i in range(9)]
            for z in [0.01 + 0.0182 * k for k in range(12)]][:106]
    bed = work / 'bed106.csv'
    bed.write_text('x,y,z,d\n' + ''.join(f'{a},{b},{c},{d}\n' for a, b, c, d in rows))
    scene = (ROOT / 'src/dempath_sim/dempath_sim/data/scenes/tiny.yaml').read_text()
    scene = scene.replace('fill: {', f'fill: {{packing: {bed}, ', 1)
    path = work / 'tiny106.yaml'
    path.write_text(scene.replace('name: tiny', 'name: tiny106', 1))
    return path


def http_server() -> str:
    """tcp:// address of a silent HTTP server in this process."""
    import http.server
    import threading

    server = http.server.ThreadingHTTPServer(('127.0.0.1', 0),
                                             http.server.SimpleHTTPRequestHandler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    return f'tcp://127.0.0.1:{server.server_address[1]}'


def frame_folder(work: Path) -> Path:
    """Two cameras x two small frames for ``dempath click``."""
    import cv2
    import numpy as np

    for camera in ('cam_side', 'cam_front'):
        (work / 'frames' / camera).mkdir(parents=True, exist_ok=True)
        for k in range(2):
            cv2.imwrite(str(work / 'frames' / camera / f'{k}.png'), np.zeros((24, 32, 3), 'u1'))
    return work / 'frames'


def diagnose(work: Path, name: str, *extra: str, scene: str = 'reduced_1ms',
             measured: Path = MEASURED, library: Path = LIBRARY, warn: str = '') -> Outcome:
    """``dempath diagnose`` on the shipped packed library with changed inputs."""
    out = work / name
    return run(['diagnose', '--measured', str(measured), '--scene', scene, '--library',
                str(library), '--origin', ORIGIN, '--out', str(out), *extra], out, warn)


def force_csv(work: Path, name: str, change: Callable[[Any], Any]) -> Path:
    """The shipped library's first baseline force as a measured force file, its times changed."""
    import numpy as np

    with np.load(LIBRARY) as data:
        t, f = np.asarray(data['r0_force_times']), np.asarray(data['r0_tool_force'])
    t = change(t)
    keep = np.isfinite(t)
    path = work / f'{name}.csv'
    path.write_text('t,Fx,Fy,Fz\n' + ''.join(f'{a:.6f},{b:.4f},{c:.4f},{d:.4f}\n'
                                             for a, (b, c, d) in zip(t[keep], f[keep],
                                                                     strict=True)))
    return path


def stiff_scene(work: Path) -> Path:
    """reduced_1ms with Young's modulus x3 (other physics under the same scene name)."""
    text = (ROOT / 'src/dempath_sim/dempath_sim/data/scenes/reduced_1ms.yaml').read_text()
    path = work / 'reduced_1ms_stiff.yaml'
    path.write_text(text.replace('youngs_modulus: {youngs_modulus_pa: 1.7e6}',
                                 'youngs_modulus: {youngs_modulus_pa: 5.1e6}'))
    assert path.read_text() != text
    return path


def measured_variant(work: Path, name: str, keep: Callable[[list[str]], bool],
                     shift_s: float = 0.0, drop_marker_column: bool = False) -> Path:
    """The field twin's measured CSV with rows kept, times shifted or the marker column cut."""
    rows = MEASURED.read_text().splitlines()
    out = []
    for row in rows[1:]:
        cells = row.split(',')
        if keep(cells):
            cells[0] = f'{float(cells[0]) + shift_s:.4f}'
            out.append(','.join(cells[:1] + cells[2:] if drop_marker_column else cells))
    header = 't,x,y,z' if drop_marker_column else rows[0]
    path = work / f'{name}.csv'
    path.write_text('\n'.join([header, *out]) + '\n')
    return path


def broken_library(work: Path, damage: str) -> Path:
    """The shipped library truncated, emptied or of an older layout."""
    sys.path.insert(0, str(ROOT / 'src/dempath_diagnose/test'))
    from test_admission import damaged_library

    return damaged_library(work / f'library_{damage}.npz', damage)


def unrecovered_bag(work: Path) -> Path:
    """A recording folder with its MCAP but no metadata.yaml (cut off)."""
    folder = work / 'cut_recording'
    folder.mkdir(exist_ok=True)
    (folder / 'cut_recording_0.mcap').write_bytes(b'\x89MCAP0\r\n')
    return folder


def diagnose_cases(work: Path) -> dict[str, Callable[[], Outcome]]:
    """The diagnosis and recalibration cases (the shipped packed library, no simulation)."""
    import numpy as np

    def f(name: str, change: Callable[[Any], Any]) -> Callable[[], Outcome]:
        return lambda: diagnose(work, f'diag_{name}', '--force',
                                str(force_csv(work, name, change)))

    return {
        'diagnose: reduced library, tiny scene': lambda: diagnose(work, 'diag_tiny',
                                                                  scene='tiny'),
        'diagnose: library, Young x3 scene': lambda: diagnose(
            work, 'diag_stiff', scene=str(stiff_scene(work))),
        'diagnose: force t in ms': f('force_ms', lambda t: t * 1e3),
        'diagnose: force t as clock time': f('force_clock', lambda t: t + 1.7e9),
        'diagnose: force covering 0-0.05 s': f('force_short',
                                                lambda t: np.where(t < 0.05, t, np.nan)),
        'diagnose: force shifted by -5 s': f('force_shift', lambda t: t - 5.0),
        'diagnose: one marker': lambda: diagnose(
            work, 'diag_one', measured=measured_variant(work, 'one', lambda c: c[1] == '3'),
            warn='thin measurement'),
        'diagnose: marker times from -5 s': lambda: diagnose(
            work, 'diag_minus5', measured=measured_variant(work, 'minus5', lambda c: True,
                                                           shift_s=-5.0)),
        'diagnose: truncated library': lambda: diagnose(
            work, 'diag_trunc', library=broken_library(work, 'truncated')),
        'diagnose: empty library': lambda: diagnose(
            work, 'diag_empty', library=broken_library(work, 'empty')),
        'diagnose: older library layout': lambda: diagnose(
            work, 'diag_old', library=broken_library(work, 'older_layout')),
        'diagnose: CSV without marker column': lambda: diagnose(
            work, 'diag_nomarker', measured=measured_variant(work, 'nomarker', lambda c: True,
                                                             drop_marker_column=True)),
        'diagnose: unrecovered bag as --measured': lambda: diagnose(
            work, 'diag_bag', measured=unrecovered_bag(work)),
        'recalibrate: --effect nonsense': lambda: run(
            ['recalibrate', '--measured', str(MEASURED), '--scene', 'reduced_1ms', '--library',
             str(LIBRARY), '--origin', ORIGIN, '--out', str(work / 'recal_nonsense'),
             '--effect', 'nonsense'], work / 'recal_nonsense'),
        'recalibrate: --diagnosis missing': lambda: run(
            ['recalibrate', '--measured', str(MEASURED), '--scene', 'reduced_1ms', '--library',
             str(LIBRARY), '--origin', ORIGIN, '--out', str(work / 'recal_nodiag'),
             '--diagnosis', str(work / 'nowhere' / 'diagnosis.json')], work / 'recal_nodiag'),
    }


def all_cases(work: Path) -> dict[str, Callable[[], Outcome]]:
    """Every case by name (each a thunk, run in order)."""
    latin = work / 'latin1.yaml'
    latin.write_bytes('name: caf\xe9\n'.encode('latin-1'))
    return {
        'simulate: non-UTF-8 scene file': lambda: run(
            ['simulate', str(latin), '--out', str(work / 'sim_latin'), '--quiet'],
            work / 'sim_latin'),
        'simulate: unknown scene': lambda: run(
            ['simulate', 'no_such_scene', '--out', str(work / 'sim_none'), '--quiet'],
            work / 'sim_none'),
        'simulate: 106-sphere packing': lambda: run(
            ['simulate', str(sparse_packing(work)), '--out', str(work / 'sim106'), '--quiet',
             '--cache-dir', str(work / 'packings')], warn='solid fraction'),
        'compare: run folder stopped while writing': lambda: run(
            ['compare', str(MEASURED), str(sim_folder(work, 'half_marker', 'marker')), '--out',
             str(work / 'cmp1'), '--no-plots'], work / 'cmp1'),
        'compare: run folder with a cut-short CSV': lambda: run(
            ['compare', str(MEASURED), str(sim_folder(work, 'half_cut', 'cut')), '--out',
             str(work / 'cmp2'), '--no-plots'], work / 'cmp2'),
        'calibrate: one damaged JPEG mid-bag': lambda: run(
            ['calibrate', str(damaged_calib_bag(work, False)), '--out', str(work / 'cal1')],
            warn='skipped'),
        'calibrate: every JPEG damaged': lambda: run(
            ['calibrate', str(damaged_calib_bag(work, True)), '--out', str(work / 'cal2')],
            work / 'cal2'),
        'demo graph: 4:3 calibration, 16:9 images': lambda: call(
            lambda: resolution_mismatch(work)),
        'packing cache: truncated entry': lambda: call(
            lambda: corrupt_packing_cache(work), warn='set aside'),
        'tool mesh: 1.2 M triangles': lambda: call(big_mesh, warn='triangles'),
        'run_id: other time step': lambda: call(run_ids_differ, warn='distinct'),
        'click: --host 0.0.0.0 without --allow-remote': lambda: run(
            ['click', str(frame_folder(work)), '--host', '0.0.0.0', '--port', '0', '--out',
             str(work / 'clicks.csv')]),
        'diagnose: --scheduler an HTTP server': lambda: run(
            ['diagnose', '--measured', str(MEASURED), '--scene', 'reduced_1ms', '--origin',
             ORIGIN, '--out', str(work / 'diag_http'), '--library-root', str(work / 'libs'),
             '--scheduler', http_server()], work / 'diag_http'),
        **diagnose_cases(work),
    }


def main() -> None:
    """Run the cases and print one JSON line last."""
    p = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    p.add_argument('--work', type=Path, help='scratch folder (default: a temporary one)')
    p.add_argument('--only', help='run only the cases whose name contains this')
    args = p.parse_args()
    work = args.work or Path(tempfile.mkdtemp(prefix='bad_inputs_'))
    work.mkdir(parents=True, exist_ok=True)
    sys.path.insert(0, str(Path(__file__).parent))
    results: dict[str, str] = {}
    totals = {'tried': 0, 'clear_error': 0, 'traceback': 0, 'silent_wrong': 0,
              'partial_outputs': 0}
    for name, case in all_cases(work).items():
        if args.only and args.only not in name:
            continue
        kind, partial = classify(case())
        totals['tried'] += 1
        totals[kind] += 1
        totals['partial_outputs'] += int(partial)
        results[name] = kind + (' +partial' if partial else '')
        print(f'{name:<46} {results[name]}', flush=True)
    if args.work is None:
        shutil.rmtree(work, ignore_errors=True)
    print(json.dumps({**totals, 'cases': results}))


if __name__ == '__main__':
    main()
