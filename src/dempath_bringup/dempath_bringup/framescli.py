"""``dempath frames``: write the TF frames file of a calibration and a scene (docs/ros.md).

The file is what the recorder's ``frames_file`` parameter (``frames:=`` of the launch files)
reads and writes to ``/tf_static`` of its bag: world, scene, field and both cameras' optical
frames (:mod:`dempath_bringup.frames`).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from dempath.errors import DempathError


def frames_main(argv: list[str]) -> int:
    """``dempath frames``: write the TF frames of a calibration and a scene for a recording."""
    parser = argparse.ArgumentParser(prog='dempath frames', description=__doc__)
    parser.add_argument('--calibration', type=Path, required=True,
                        help='stereo calibration YAML (dempath calibrate)')
    parser.add_argument('--scene', required=True, help='scene file or shipped scene name')
    parser.add_argument('--out', type=Path, default=Path('frames.yaml'), help='frames YAML')
    args = parser.parse_args(argv)
    from dempath.frames import save_frames
    from dempath_bringup.frames import graph_frames

    try:
        transforms = graph_frames(args.calibration, args.scene)
        save_frames(args.out, transforms)
    except DempathError as err:
        print(f'error: {err}', file=sys.stderr)
        return 1
    except OSError as err:
        print(f'error: {args.out}: cannot write ({err.strerror})', file=sys.stderr)
        return 1
    for t in transforms:
        print(f'{t.parent} -> {t.child}: translation {[round(v, 4) for v in t.translation]} m')
    print(f'{args.out}: {len(transforms)} transforms')
    return 0
