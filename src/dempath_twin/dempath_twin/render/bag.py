"""Write a rendered field recording as a rosbag2 MCAP bag, and ``dempath twin render``.

``dempath twin render SCENE_OR_RUN --out BAG`` takes a dempath_sim run folder (with bed
snapshots at least as dense as the frames) or a scene (then runs it first, with dense
snapshots, into ``BAG.run/``), renders both cameras of the twin rig and writes the bag and
``BAG.truth.json``. Per camera: ``/<cam>/image_raw/compressed`` (``sensor_msgs/CompressedImage``,
JPEG bgr8) and ``/<cam>/camera_info`` (``sensor_msgs/CameraInfo``, the rig's nominal
intrinsics), header stamps from each camera's clock.
"""

from __future__ import annotations

import argparse
import logging
import shutil
import sys
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import cv2
import numpy as np
from numpy.typing import NDArray

from dempath import topics
from dempath.bagio import write_bag
from dempath.errors import DempathError
from dempath.typestore import make_typestore
from dempath_twin.images import jpeg_message, stamp_header
from dempath_twin.render.bed_source import BedRecord, load_bed, run_for_recording
from dempath_twin.render.camera_frame import CLAY_BGR, SAND_BGR, Look
from dempath_twin.render.coverage import on_surface
from dempath_twin.render.recording import (
    CALIB_GAP_S,
    START_NS,
    FrameTruth,
    RecordingConfig,
    cameras_for,
    field_frames,
    save_truth,
    truth_json,
)

if TYPE_CHECKING:
    from dempath_sim.scene import SceneSpec

LOG = logging.getLogger(__name__)


def camera_info(types: Any, camera: Any, stamp_ns: int) -> Any:
    """``sensor_msgs/CameraInfo`` of a CameraModel (plumb_bob, no rectification)."""
    k = np.asarray(camera.K, np.float64)
    p = np.hstack([k, np.zeros((3, 1))])
    roi = types['sensor_msgs/msg/RegionOfInterest'](x_offset=0, y_offset=0, height=0, width=0,
                                                    do_rectify=False)
    return types['sensor_msgs/msg/CameraInfo'](
        header=stamp_header(types, stamp_ns, f'{camera.name}_optical'), height=camera.height,
        width=camera.width, distortion_model='plumb_bob',
        d=np.asarray(camera.dist, np.float64), k=k.ravel(), r=np.eye(3).ravel(), p=p.ravel(),
        binning_x=0, binning_y=0, roi=roi)


def image_messages(types: Any, camera: Any, image: NDArray[np.uint8], stamp_ns: int,
                   quality: int) -> Iterator[tuple[str, str, int, Any]]:
    """The JPEG image and the CameraInfo of one frame as bag messages."""
    msg = jpeg_message(types, stamp_header(types, stamp_ns, f'{camera.name}_optical'), image,
                       quality, 'bgr8; jpeg compressed bgr8')
    yield (topics.camera_topic(topics.IMAGE_COMPRESSED, camera.name),
           'sensor_msgs/msg/CompressedImage', stamp_ns, msg)
    yield (topics.camera_topic(topics.CAMERA_INFO, camera.name), 'sensor_msgs/msg/CameraInfo',
           stamp_ns, camera_info(types, camera, stamp_ns))


def calibration_frames(rig: Any, config: RecordingConfig,
                       ) -> tuple[list[tuple[int, NDArray[np.uint8], int]], dict[str, Any]]:
    """The calibration segment: ``(camera index, BGR image, stamp)`` and its truth."""
    from dempath_calib.camera import StereoCalibration
    from dempath_twin.board.recording import calibration_poses, render_views, truth_dict

    if config.calib_views == 0:
        return [], {'views': 0}
    side, front = cameras_for(rig, config)
    small = StereoCalibration(side, front, {'source': 'twin rig at the recording scale'})
    poses = calibration_poses(config.calib_views, config.seed, small)
    frames = []
    for i, images in enumerate(render_views(poses, config.seed, small)):
        for c, grey in enumerate(images):
            t = i * config.calib_period_s + (config.front_offset_s if c else 0.0)
            bgr = np.asarray(cv2.cvtColor(grey, cv2.COLOR_GRAY2BGR), np.uint8)
            frames.append((c, bgr, START_NS + round(t * 1e9)))
    truth = truth_dict(small, _board(), poses)
    truth['views'] = config.calib_views
    truth['period_s'] = config.calib_period_s
    return frames, truth


def _board() -> Any:
    from dempath_calib.board import PAPER_BOARD

    return PAPER_BOARD


def write_field_recording(bed: BedRecord, rig: Any, out: Path,
                          config: RecordingConfig) -> tuple[Path, list[FrameTruth]]:
    """Render the calibration segment and the run into the bag ``out``; truth beside it."""
    store = make_typestore()
    cams = cameras_for(rig, config)
    calib, calib_truth = calibration_frames(rig, config)
    t0 = (config.calib_views * config.calib_period_s + CALIB_GAP_S) if calib else 0.0
    truth: list[FrameTruth] = []

    def messages() -> Iterator[tuple[str, str, int, Any]]:
        for c, image, stamp in calib:
            yield from image_messages(store.types, cams[c], image, stamp, config.jpeg_quality)
        names = [c.name for c in cams]
        for name, image, stamp in field_frames(bed, rig, config, t0, truth):
            cam = cams[names.index(name)]
            yield from image_messages(store.types, cam, image, stamp, config.jpeg_quality)

    if out.exists():
        shutil.rmtree(out)
    write_bag(out, messages(), typestore=store)
    calib_truth['field_start_ns'] = START_NS + round(t0 * 1e9)
    data = truth_json(truth, bed, _origin(bed), rig, config, calib_truth)
    data['on_surface'] = on_surface(bed, config).astype(int).tolist()
    data['on_surface_means'] = ('per frame and marker: at least half its disc seen from '
                                'straight above, grains only (dempath_twin.render.coverage)')
    save_truth(out, data)
    return out, truth


def _origin(bed: BedRecord) -> Any:
    from dempath_twin.render.recording import grid_origin

    return grid_origin(bed)


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog='dempath twin render',
                                description=(__doc__ or '').splitlines()[0])
    p.add_argument('source', help='dempath_sim run folder (result.npz) or scene file / name')
    p.add_argument('--out', type=Path, required=True, help='bag folder to create')
    p.add_argument('--scale', type=float, default=1.0, help='sensor scale of 1920x1080')
    p.add_argument('--frames', type=int, help='render at most this many run frames')
    p.add_argument('--quality', type=int, default=85, help='JPEG quality')
    p.add_argument('--calib-views', type=int, default=12, help='calibration board views')
    p.add_argument('--exposure', type=float, default=0.004, help='exposure time [s]')
    p.add_argument('--front-offset', type=float, default=0.003,
                   help='front camera clock and exposure offset [s]')
    p.add_argument('--start', type=float, default=0.0, help='run time of the first frame [s]')
    p.add_argument('--blur-subframes', type=int, default=3, help='sub-frames per exposure')
    p.add_argument('--light', type=float, default=1.0,
                   help='light level relative to the default scene')
    p.add_argument('--flicker', type=float, default=0.0,
                   help='light change from frame to frame: each frame x (1 + F u), u in [-1, 1]')
    p.add_argument('--cloud', type=float, default=1.0,
                   help='lowest relative light while a cloud passes mid-pass (1: none)')
    p.add_argument('--noise', type=float, default=2.0, help='read noise [grey levels]')
    p.add_argument('--ambient', type=float, default=0.35,
                   help='share of light reaching shadowed surfaces')
    p.add_argument('--sand-bgr', type=_bgr, default=SAND_BGR, help='sand albedo B,G,R (0-1)')
    p.add_argument('--marker-bgr', type=_bgr, default=CLAY_BGR,
                   help='marker (clay) albedo B,G,R (0-1)')
    p.add_argument('--marker-diameter', type=float, default=0.008,
                   help='marker sphere diameter [m]')
    p.add_argument('--seed', type=int, default=0)
    p.add_argument('--hidden-seed', type=int, help='packing seed when SOURCE is a scene')
    p.add_argument('--on', action='append', default=[],
                   help='effect on when SOURCE is a scene (an effect that is always on, such as '
                        'tool_speed, keeps its default: set it with --effect)')
    p.add_argument('--effect', action='append', default=[], metavar='EFFECT.PARAM=VALUE',
                   help='set an effect parameter when SOURCE is a scene (switches the effect '
                        'on), e.g. tool_speed.speed_scale=2 for a tool driven twice as fast; '
                        'repeatable')
    p.add_argument('--rig', default='fixed', choices=('fixed', 'carriage'),
                   help="the twin's cameras: 'fixed' (paper_rig) or 'carriage' (carriage_rig)")
    return p


def _bgr(text: str) -> tuple[float, float, float]:
    """``'B,G,R'`` albedo in 0-1 (an argparse type)."""
    parts = text.split(',')
    try:
        values = tuple(float(p) for p in parts)
    except ValueError:
        values = ()
    if len(values) != 3:
        raise argparse.ArgumentTypeError(f'{text!r}: want B,G,R, three numbers in 0-1')
    return values[0], values[1], values[2]


def render_scene(source: str, effects: list[str], on: list[str], seed: int | None,
                 ) -> SceneSpec:
    """The scene a render runs when its source is a scene: ``effects`` are
    ``EFFECT.PARAM=VALUE`` settings (as ``dempath simulate --effect``), ``on`` effects switched
    on at their values, ``seed`` the packing seed (None: the scene's). Why ``effects`` too:
    switching on an effect that is always on (``tool_speed``) keeps its default, so
    ``--on tool_speed`` alone renders the scene's own speed; SceneError on a bad setting."""
    from dempath_sim.scene import parse_overrides, resolve_scene

    return resolve_scene(source).with_overrides(parse_overrides(effects), on=on, seed=seed)


def _bed(args: argparse.Namespace, fps: float) -> BedRecord:
    source = Path(args.source)
    if (source / 'result.npz').is_file():
        return load_bed(source, fps)
    scene = render_scene(args.source, args.effect, args.on, args.hidden_seed)
    run_dir = args.out.with_name(args.out.name + '.run')
    return load_bed(run_for_recording(scene, run_dir, fps), fps, scene)


def render_main(argv: list[str] | None = None) -> int:
    """``dempath twin render SCENE_OR_RUN --out BAG``; one error line and 1 on bad input."""
    from dempath_twin.rig import RIGS

    args = _parser().parse_args(argv)
    try:
        config = RecordingConfig(scale=args.scale, jpeg_quality=args.quality,
                                 calib_views=args.calib_views, max_frames=args.frames,
                                 front_offset_s=args.front_offset, seed=args.seed,
                                 start_s=args.start,
                                 look=replace(Look(), exposure_s=args.exposure,
                                              blur_subframes=args.blur_subframes,
                                              light=args.light, noise_dn=args.noise,
                                              ambient=args.ambient, sand_bgr=args.sand_bgr,
                                              marker_bgr=args.marker_bgr,
                                              marker_diameter_m=args.marker_diameter,
                                              flicker=args.flicker, cloud=args.cloud))
        bed = _bed(args, config.fps)
        out, truth = write_field_recording(bed, RIGS[args.rig](), args.out, config)
    except (DempathError, OSError, ValueError) as err:
        print(f'error: {args.source}: {" ".join(str(err).split())}', file=sys.stderr)
        return 1
    size = sum(f.stat().st_size for f in out.iterdir())
    print(f'{out}: {len(truth) // 2} frames per camera, {size / 1e6:.1f} MB, truth in '
          f'{out.name}.truth.json')
    return 0
