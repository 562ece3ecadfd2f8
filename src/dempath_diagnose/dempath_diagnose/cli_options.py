"""The options ``dempath diagnose`` and ``dempath recalibrate`` share, and their parsing into a
:class:`~dempath_diagnose.entry.requests.DiagnoseRequest`.

Part of the two commands (nothing below them takes parsed arguments): numbers and lists are
turned into typed values here, and a bad one is a :class:`DiagnosisError` naming the option.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from dempath_diagnose.decision.emulator import Allowance
from dempath_diagnose.entry.requests import DiagnoseRequest
from dempath_diagnose.errors import DiagnosisError
from dempath_diagnose.library.packed import DEFAULT_MARGIN_M
from dempath_diagnose.library.simulator import BACKENDS, LIBRARY_CANDIDATES


def diagnose_parser(prog: str, description: str) -> argparse.ArgumentParser:
    """The parser of the diagnosis options (the recalibration adds its own)."""
    p = argparse.ArgumentParser(prog=prog, description=description)
    p.add_argument('--measured', required=True, type=Path,
                   help='CSV t,marker,x,y,z [s, m] or a bag with MarkerPoints3D')
    p.add_argument('--scene', required=True, help='scene file or shipped scene (builtin:tiny)')
    p.add_argument('--force', type=Path, help='CSV t,Fx,Fy,Fz [s, N], force on the tool')
    p.add_argument('--origin', default='0,0,0',
                   help='measured frame origin in the scene frame, X,Y,Z [m]')
    p.add_argument('--out', required=True, type=Path, help='output folder')
    p.add_argument('--scheduler', help='Dask scheduler address (default: a local cluster)')
    p.add_argument('--workers', type=int, default=0, help='local Dask workers (0: by cores)')
    p.add_argument('--library-root', type=Path, help='signature library cache folder')
    p.add_argument('--packing-cache', type=Path, help='packing cache folder')
    p.add_argument('--seeds', default='1001,1002,1003', help='library packing seeds')
    p.add_argument('--candidates', default=','.join(LIBRARY_CANDIDATES),
                   help='candidate effects, comma-separated')
    p.add_argument('--strengths', type=int, default=2, help='strengths per candidate (1 or 2)')
    p.add_argument('--windows', type=int, default=4, help='time windows of the statistics')
    p.add_argument('--noise', type=float, default=Allowance.noise_m,
                   help='measurement noise per axis [m]')
    p.add_argument('--discrepancy', type=float, default=Allowance.discrepancy_m,
                   help='model-discrepancy allowance on marker statistics [m]')
    p.add_argument('--discrepancy-rel', type=float, default=Allowance.discrepancy_rel,
                   help='relative model-discrepancy allowance on marker statistics')
    p.add_argument('--discrepancy-force', type=float, default=Allowance.discrepancy_force_rel,
                   help='relative model-discrepancy allowance on the draft force')
    p.add_argument('--serial', action='store_true', help='run the library here, without Dask')
    p.add_argument('--model', type=Path,
                   help="the paper's Table 7 against this model run of yours instead of the "
                        "library's baseline band: dempath CSV, a LIGGGHTS dump or a mapped "
                        'EDEM/Rocky CSV (with --model-map)')
    p.add_argument('--model-map', type=Path, metavar='YAML',
                   help='how to read --model: columns, units, axes (docs/compare.md)')
    p.add_argument('--backend', choices=BACKENDS, default='dempath',
                   help="engine of the library's runs (liggghts: LIGGGHTS 3.8 from the same "
                        'settled beds)')
    p.add_argument('--library', type=Path,
                   help='use this library (a packed file or a library folder); never built')
    p.add_argument('--export-library', type=Path, metavar='FILE',
                   help="also pack the library into FILE for the measured markers' region")
    p.add_argument('--export-margin', type=float, default=DEFAULT_MARGIN_M,
                   help="packed: particles within this of a marker's cube are kept [m]")
    p.add_argument('--export-box', help='packed: keep the particles starting in this box, '
                   'X0,Y0,Z0,X1,Y1,Z1 [m] (scene frame), besides those near the markers')
    p.add_argument('--held-out', default='', metavar='M,M,...',
                   help='markers left out of the diagnosis and the fit, scored apart before '
                        'and after (a held-out check of the fit)')
    return p


def diagnose_request(args: argparse.Namespace, budget: int) -> DiagnoseRequest:
    """The request of the parsed diagnosis options, with ``budget`` simulations beyond the
    library.

    Raises:
        DiagnosisError: An option that is not what it should be (one line naming it).
    """
    box = None
    if args.export_box:
        b = floats(args.export_box, '--export-box', 6)
        box = (b[0], b[1], b[2], b[3], b[4], b[5])
    o = floats(args.origin, '--origin', 3)
    return DiagnoseRequest(
        measured=args.measured, scene=args.scene, out=args.out, force=args.force,
        origin=(o[0], o[1], o[2]), library=args.library, library_root=args.library_root,
        packing_cache=args.packing_cache, backend=args.backend,
        seeds=ints(args.seeds, '--seeds'),
        candidates=tuple(c for c in args.candidates.split(',') if c),
        strengths=args.strengths, windows=args.windows,
        allowance=Allowance(args.noise, args.discrepancy, args.discrepancy_rel,
                            args.discrepancy_force),
        serial=args.serial, scheduler=args.scheduler, workers=args.workers, budget=budget,
        model=args.model, model_map=args.model_map, export_library=args.export_library,
        export_margin=args.export_margin, export_box=box,
        held_out=ints(args.held_out, '--held-out'))


def floats(text: str, what: str, n: int) -> list[float]:
    """``n`` finite numbers separated by commas (option ``what``)."""
    try:
        values = [float(v) for v in text.split(',')]
    except ValueError as err:
        raise DiagnosisError(f'{what} {text!r}: expected {n} numbers in metres') from err
    if len(values) != n or not all(math.isfinite(v) for v in values):
        raise DiagnosisError(f'{what} {text!r}: expected {n} finite numbers separated by commas')
    return values


def ints(text: str, what: str) -> tuple[int, ...]:
    """Integers separated by commas (option ``what``)."""
    try:
        return tuple(int(v) for v in text.split(',') if v.strip())
    except ValueError as err:
        raise DiagnosisError(f'{what} {text!r}: expected integers separated by commas') from err
