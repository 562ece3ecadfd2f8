"""``dempath calib-check CALIB INPUT...``: judge calibrations on a recording of the board.

Detects the board in both cameras of the recording (the inputs of ``dempath calibrate``), pairs
the frames at the clock offset the board's motion gives (or ``--offset``), interpolating the
front corners to the side camera's instants, and prints for each calibration the board's
rigidity (all corner-pair distances against the printed board) and the epipolar error, with the
frames paired as recorded beside them.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from dempath.errors import DempathError
from dempath_calib.check import (
    CalibrationCheck,
    check_calibrations,
    detect_streams,
    estimate_offset,
    load_calibration,
    pair_streams,
)
from dempath_calib.cli import add_board_options, board_from_args
from dempath_calib.sources import open_source


def calib_check_parser() -> argparse.ArgumentParser:
    """Options of ``dempath calib-check``."""
    p = argparse.ArgumentParser(prog='dempath calib-check', description='Board rigidity and '
                                'epipolar error of calibrations on a board recording.')
    p.add_argument('calib', help='calibration folder, stereo.yaml or Caliscope camera_array.toml')
    p.add_argument('inputs', nargs='+', help='bag | frame folder | side.mp4 front.mp4')
    p.add_argument('--against', action='append', default=[],
                   help='another calibration to check on the same frames (repeatable)')
    add_board_options(p)
    p.add_argument('--offset', default='auto',
                   help="front clock offset [s], or 'auto' (from the board's motion)")
    p.add_argument('--max-offset', type=float, default=0.5, help='search range of auto [s]')
    p.add_argument('--timestamps', help='CSV with cam_id,frame_time per video frame')
    p.add_argument('--fps', type=float, default=30.0, help='frame rate of a frame folder')
    p.add_argument('--json', action='store_true', help='print one JSON line instead of tables')
    return p


def calib_check_main(argv: list[str]) -> int:
    """``dempath calib-check``: board rigidity and epipolar error of calibrations."""
    args = calib_check_parser().parse_args(argv)
    try:
        board = board_from_args(args)
        calibs = {p: load_calibration(p) for p in [args.calib, *args.against]}
        source = open_source(args.inputs, args.fps, args.timestamps)
        streams = detect_streams(source.frames(), board)
        out: dict[str, Any] = {'pairings': {}}
        offsets = {'recorded': 0.0}
        if args.offset == 'auto':
            motion = estimate_offset(streams, calibs[args.calib], board, args.max_offset)
            out['motion'] = {'offset_s': motion.offset_s, 'rms_mm': motion.rms_mm,
                             'rms_as_recorded_mm': motion.rms_zero_mm}
            offsets['motion'] = motion.offset_s
        else:
            offsets['given'] = float(args.offset)
        for label, off in offsets.items():
            checks = check_calibrations(calibs, pair_streams(streams, off), board)
            out['pairings'][label] = {'offset_s': off, 'checks': checks}
    except ValueError as err:
        print(f'error: options: {err}', file=sys.stderr)
        return 1
    except DempathError as err:
        print(f'error: {err}', file=sys.stderr)
        return 1
    if args.json:
        print(json.dumps({**out, 'pairings': {k: {'offset_s': v['offset_s'], 'checks': [
            c.summary() for c in v['checks']]} for k, v in out['pairings'].items()}}))
    else:
        _print_tables(out)
    return 0


def _print_tables(out: dict[str, Any]) -> None:
    """The checks as rich tables: one headline table, one by corner separation."""
    from rich.console import Console
    from rich.table import Table

    console = Console()
    console.width = max(console.width, 100)  # the tables need 100 columns
    if 'motion' in out:
        m = out['motion']
        console.print(f"front clock offset from the board's motion: {m['offset_s']:+.3f} s "
                      f"(motion mismatch {m['rms_mm']:.2f} mm; {m['rms_as_recorded_mm']:.2f} mm "
                      'as recorded)')
    head = Table(title='calibration checks (lengths: triangulated - printed)')
    for col in ('calibration', 'pairing', 'offset s', 'frames', 'RMS mm', 'max mm', 'scale ppm',
                'epi RMS px', 'epi max'):
        head.add_column(col, justify='left' if col in ('calibration', 'pairing') else 'right')
    seps = Table(title='RMS length error \\[mm] by printed separation')
    seps.add_column('calibration')
    seps.add_column('pairing')
    last = list(out['pairings'].values())[-1]['checks']
    for b in (last[0].rigidity.bins if last else []):
        seps.add_column(f'{b.low_mm:.0f}-{b.high_mm:.0f} mm', justify='right')
    for label, pairing in out['pairings'].items():
        c: CalibrationCheck
        for c in pairing['checks']:
            s = c.summary()
            r, e = s['rigidity'], s['epipolar']
            head.add_row(_label(c.name), label, f"{pairing['offset_s']:+.3f}",
                         f"{r['frames']}", f"{r['rms_mm']:.3f}", f"{r['max_mm']:.3f}",
                         f"{r['scale_ppm']:+.0f}",
                         *(f'{e[k]:.2f}' if e['n'] else '-' for k in ('rms_px', 'max_px')))
            seps.add_row(_label(c.name), label, *(f'{b.rms_mm:.3f}' for b in c.rigidity.bins))
    console.print(head)
    console.print(seps)


def _label(path: str) -> str:
    """Short name of a calibration: its folder's name, or its file's stem."""
    p = Path(path)
    return p.name if p.is_dir() or not p.suffix else p.stem
