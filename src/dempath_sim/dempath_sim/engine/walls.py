"""Plane walls of the bin: infinite planes with an inward unit normal and a material.

A sphere of radius r at x touches the plane (point p, normal n) when its signed distance
s = (x - p) . n is below r; the overlap is delta = r - s and the contact normal is n
(from the wall to the particle). Contact laws: see `laws/dispatch.py` (R* = r, m* = m).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from dempath_sim.errors import GeometryError


@dataclass(frozen=True)
class Plane:
    """An infinite plane wall.

    Attributes:
        point: A point on the plane (3,) [m].
        normal: Normal (3,) pointing into the domain (normalised on construction).
        material: Material index into SimParams.materials.
    """

    point: tuple[float, float, float]
    normal: tuple[float, float, float]
    material: int = 0

    def __post_init__(self) -> None:
        """Normalise the normal; raise GeometryError for a zero or non-finite one."""
        nrm = np.asarray(self.normal, dtype=np.float64)
        pnt = np.asarray(self.point, dtype=np.float64)
        length = float(np.linalg.norm(nrm))
        if nrm.shape != (3,) or pnt.shape != (3,) or not math.isfinite(length) or length == 0:
            msg = f'Plane(point={self.point!r}, normal={self.normal!r}): need finite 3-vectors ' \
                  f'and a non-zero normal'
            raise GeometryError(msg)
        if not np.isfinite(pnt).all():
            msg = f'Plane.point must be finite, got {self.point!r}'
            raise GeometryError(msg)
        object.__setattr__(self, 'normal', tuple(float(v) for v in nrm / length))
        object.__setattr__(self, 'point', tuple(float(v) for v in pnt))


def box_walls(lo: tuple[float, float, float], hi: tuple[float, float, float], material: int = 0,
              open_top: bool = True) -> tuple[Plane, ...]:
    """The walls of an axis-aligned box [lo, hi] (Y up), optionally without the top (+Y) lid.

    Args:
        lo: Lower corner (3,) [m].
        hi: Upper corner (3,) [m].
        material: Material index of all walls.
        open_top: Leave out the plane y = hi[1].

    Returns:
        5 or 6 planes with inward normals.
    """
    if any(a >= b for a, b in zip(lo, hi, strict=True)):
        msg = f'box_walls: lo {lo!r} must be below hi {hi!r} on every axis'
        raise GeometryError(msg)
    planes = []
    for axis in range(3):
        for side, corner in ((1.0, lo), (-1.0, hi)):
            if open_top and axis == 1 and side < 0:
                continue
            normal = [0.0, 0.0, 0.0]
            normal[axis] = side
            planes.append(Plane(tuple(corner), tuple(normal), material))  # type: ignore[arg-type]
    return tuple(planes)


def pack_planes(planes: tuple[Plane, ...]) -> tuple[NDArray[np.float64], NDArray[np.int32]]:
    """Arrays for the kernels: (n_planes, 6) point and normal, (n_planes,) material."""
    if not planes:
        return np.zeros((0, 6)), np.zeros(0, np.int32)
    geo = np.array([p.point + p.normal for p in planes], dtype=np.float64)
    return geo, np.array([p.material for p in planes], dtype=np.int32)
