"""``dempath calibrate``: calibrate from a bag, frame folder or two videos (``dempath rig``, the
twin's calibration recording, is in dempath_twin)."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Iterator
from dataclasses import replace
from itertools import chain

from dempath.errors import DempathError
from dempath_calib.board import CALISCOPE_BOARD, PAPER_BOARD, BoardKind, BoardSpec
from dempath_calib.calibrator import CalibrationConfig, Calibrator
from dempath_calib.errors import CalibrationError
from dempath_calib.intrinsics import DistortionModel
from dempath_calib.opencv_check import require_charuco_opencv
from dempath_calib.outputs import save_result
from dempath_calib.sources import Frame, open_source

BOARDS = {'paper': PAPER_BOARD, 'caliscope': CALISCOPE_BOARD}


def add_board_options(p: argparse.ArgumentParser) -> None:
    """The board options shared by ``dempath calibrate`` and ``dempath calib-check``."""
    p.add_argument('--board', choices=sorted(BOARDS), default='paper',
                   help='preset board (paper: 7x5 40.4 mm DICT_5X5_100)')
    p.add_argument('--columns', type=int, help='squares along x')
    p.add_argument('--rows', type=int, help='squares along y')
    p.add_argument('--square', type=float, help='square side [m]')
    p.add_argument('--marker', type=float, help='marker side [m]')
    p.add_argument('--dictionary', help='OpenCV dictionary, e.g. DICT_5X5_100')
    p.add_argument('--chessboard', action='store_true', help='plain chessboard target')
    p.add_argument('--inverted', action='store_true', help='board printed white on black')


def board_from_args(args: argparse.Namespace) -> BoardSpec:
    """The board of ``add_board_options``' options: the preset with the given changes."""
    board = BOARDS[args.board]
    changes = {k: v for k, v in (('columns', args.columns), ('rows', args.rows),
                                 ('square_m', args.square), ('marker_m', args.marker),
                                 ('dictionary', args.dictionary)) if v is not None}
    if args.chessboard:
        changes['kind'] = BoardKind.CHESSBOARD
    if args.inverted:
        changes['inverted'] = True
    return replace(board, **changes) if changes else board


def calibrate_parser() -> argparse.ArgumentParser:
    """Options of ``dempath calibrate``."""
    p = argparse.ArgumentParser(prog='dempath calibrate', description='Two-camera calibration '
                                'from a bag, a folder of frames (cam_side/, cam_front/) or two '
                                'videos (side first).')
    p.add_argument('inputs', nargs='+', help='bag | frame folder | side.mp4 front.mp4')
    p.add_argument('--out', required=True, help='output folder')
    add_board_options(p)
    p.add_argument('--distortion', default='k1k2p1p2k3',
                   choices=[m.value for m in DistortionModel], help='distortion model')
    p.add_argument('--world', default='surface', choices=['surface', 'side'],
                   help='world frame: board on the sand in the first frames, or side camera')
    p.add_argument('--offset', default='0', help="front clock offset [s], or 'auto'")
    p.add_argument('--max-offset', type=float, default=0.5,
                   help='search range of --offset auto [s]')
    p.add_argument('--timestamps', help='CSV with cam_id,frame_time per video frame')
    p.add_argument('--fps', type=float, default=30.0, help='frame rate of a frame folder')
    p.add_argument('--every', type=int, default=1, help='use every n-th image')
    p.add_argument('--width', type=int, help='image width [px] (default: from the images)')
    p.add_argument('--height', type=int, help='image height [px]')
    p.add_argument('--min-views', type=int, default=8, help='least usable views per camera')
    return p


def _config(args: argparse.Namespace, size: tuple[int, int]) -> CalibrationConfig:
    try:
        offset = None if args.offset == 'auto' else float(args.offset)
        return CalibrationConfig(board=board_from_args(args),
                                 distortion=DistortionModel(args.distortion),
                                 world=args.world, offset_s=offset, image_size=size,
                                 min_views=args.min_views, max_offset_s=args.max_offset)
    except ValueError as err:
        msg = f'options: {err}'
        raise CalibrationError(msg) from err


def calibrate_main(argv: list[str]) -> int:
    """``dempath calibrate INPUT... --out DIR``: calibrate and write the output files."""
    args = calibrate_parser().parse_args(argv)
    try:
        if BOARDS[args.board].kind is BoardKind.CHARUCO:
            require_charuco_opencv()
        source = open_source(args.inputs, args.fps, args.timestamps)
        frames = source.frames()
        first = next(frames, None)
        if first is None:
            msg = f'{args.inputs[0]}: no images'
            raise CalibrationError(msg)
        size = (args.width or first[2].shape[1], args.height or first[2].shape[0])
        cal = Calibrator(_config(args, size))
        _collect(cal, first, frames, source.count(), args.every)
        result = cal.solve()
        paths = save_result(result, args.out, {'inputs': args.inputs})
    except DempathError as err:  # calibration, input, bag and output errors
        print(f'error: {err}', file=sys.stderr)
        return 1
    rep = result.report
    print(json.dumps({'rmse_px': rep['rmse_px'], 'intrinsic_rmse_px': rep['intrinsic_rmse_px'],
                      'views': rep['views'], 'offset_s': rep.get('offset_s'),
                      'corner_spacing_mm': rep['corner_spacing'].get('mean_mm'),
                      'point_set_size': rep['point_set_size'],
                      'undecodable_images': len(getattr(source, 'undecodable', ())),
                      'outputs': [str(p) for p in paths.values()]}))
    return 0


def _collect(cal: Calibrator, first: Frame, frames: Iterator[Frame], total: int,
             every: int) -> None:
    """Feed every ``every``-th image per camera to the calibrator with a progress bar."""
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn

    counts = [0, 0]
    columns = (TextColumn('detecting'), BarColumn(), MofNCompleteColumn(),
               TextColumn('{task.fields[state]}'))
    with Progress(*columns, console=Console(stderr=True), transient=True) as bar:
        task = bar.add_task('detecting', total=total, state='')
        for cam, stamp, image in chain([first], frames):
            if counts[cam] % every == 0:
                cal.add_image(cam, stamp, image)
            counts[cam] += 1
            bar.update(task, advance=1, state=cal.progress().line())
