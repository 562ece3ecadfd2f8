"""Generate ``chisel.stl``, the full-scale chisel tine shipped with dempath_sim.

The paper (Kuře & Kuřetová, Technologies 2025, 13, 570, Sec. 2.1 and Fig. 3) used a full-scale
steel chisel but gives no drawing, so this is a typical medium-depth chisel tine designed from
common practice: a 60 mm wide, 12 mm thick share of 170 mm inclined at 25 deg to the horizontal,
and a 30 mm wide, 60 mm deep vertical shank with a wedge-shaped leading edge up to 600 mm above
the tip. Units are metres; the origin is the tip of the share (the tool's reference point, the
lowest and foremost point); the tool travels along +Z, Y is up, X lateral. Each part is a closed
convex shell (overlapping shells are fine for contact detection). Run:

    python make_chisel_stl.py [OUT.stl]
"""

from __future__ import annotations

import math
import struct
import sys
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import ConvexHull

SHARE_WIDTH = 0.060  # m, X
SHARE_LENGTH = 0.170  # m, along the share
SHARE_THICKNESS = 0.012  # m
SHARE_ANGLE = math.radians(25.0)  # rake angle to the horizontal
SHANK_WIDTH = 0.030  # m, X
SHANK_DEPTH = 0.060  # m, Z (without the leading wedge)
SHANK_WEDGE = 0.025  # m, length of the leading wedge along Z
SHANK_TOP = 0.600  # m, Y of the top of the shank above the tip


def share_points() -> NDArray[np.float64]:
    """Corner points (n, 3) m of the share: a plate rising backwards from the tip edge."""
    back_z = -SHARE_LENGTH * math.cos(SHARE_ANGLE)
    back_y = SHARE_LENGTH * math.sin(SHARE_ANGLE)
    w = SHARE_WIDTH / 2
    pts = []
    for x in (-w, w):
        pts += [(x, 0.0, 0.0), (x, back_y, back_z),
                (x, SHARE_THICKNESS, -SHARE_THICKNESS / math.tan(SHARE_ANGLE) * 0.5),
                (x, back_y + SHARE_THICKNESS, back_z)]
    return np.array(pts)


def shank_points() -> NDArray[np.float64]:
    """Corner points (n, 3) m of the shank: a vertical plate with a wedge leading edge."""
    w = SHANK_WIDTH / 2
    z_front = -SHARE_LENGTH * math.cos(SHARE_ANGLE) * 0.55
    z_back = z_front - SHANK_WEDGE - SHANK_DEPTH
    y_low = SHARE_LENGTH * math.sin(SHARE_ANGLE) * 0.55
    pts = []
    for y in (y_low, SHANK_TOP):
        pts += [(0.0, y, z_front), (-w, y, z_front - SHANK_WEDGE), (w, y, z_front - SHANK_WEDGE),
                (-w, y, z_back), (w, y, z_back)]
    return np.array(pts)


def hull_triangles(points: NDArray[np.float64]) -> NDArray[np.float64]:
    """Triangles (m, 3, 3) m of the convex hull with outward (counter-clockwise) winding."""
    hull = ConvexHull(points)
    centre = points.mean(axis=0)
    tris = points[hull.simplices]
    normals = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    flip = np.einsum('ij,ij->i', normals, tris.mean(axis=1) - centre) < 0
    tris[flip] = tris[flip][:, ::-1]
    return np.asarray(tris, dtype=np.float64)


def write_binary_stl(path: Path, triangles: NDArray[np.float64], name: str) -> None:
    """Write triangles (m, 3, 3) as a binary STL with unit facet normals."""
    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    with path.open('wb') as f:
        f.write(name.encode('ascii').ljust(80, b' ')[:80])
        f.write(struct.pack('<I', len(triangles)))
        for n, tri in zip(normals, triangles, strict=True):
            f.write(struct.pack('<12fH', *n, *tri.ravel(), 0))


def main(argv: list[str]) -> int:
    """Write the chisel to ``argv[0]`` (default: chisel.stl next to this script)."""
    out = Path(argv[0]) if argv else Path(__file__).with_name('chisel.stl')
    tris = np.concatenate([hull_triangles(share_points()), hull_triangles(shank_points())])
    write_binary_stl(out, tris, 'dempath chisel tine, metres, tip at origin, travel +Z')
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
