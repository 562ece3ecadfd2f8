"""One joint assignment per pair of frames: markers to cross-camera pairs or to one camera's ray.

Each marker may take a pair of detections (one in each camera: a 3D point), a single
detection of one camera (its line of sight, when the other camera does not see it) or
nothing. An option's cost is the negative log-likelihood of the evidence under the marker's
prediction, in units of chi-square: for a pair, the 3D distance of the triangulated point from
the predicted one over the prediction's uncertainty, squared, plus the squared epipolar residual
over its noise (the epipolar constraint is inside the assignment, not a check afterwards); for a
ray, the image distance from the predicted projection over the uncertainty seen in that camera,
squared, plus half the cost of a miss (the marker goes unseen in the other camera). Taking
nothing costs ``MISS``: splitting a pair into two markers' rays must not pay. Each
detection serves at most one marker (two where the detector flags a spot as two touching
markers). The problem is solved exactly, separately on each connected group of markers that
compete for detections (most markers compete with nobody): ``scipy.optimize.milp`` (HiGHS)
on the binary option variables.

A marker is *ambiguous in a camera* when, forced off the detection it took in that camera, the
best joint assignment gives it another detection there, or gives that detection to another
marker, at a total cost less than ``margin`` higher: two markers that touch or cross in one
view are left unnumbered there rather than guessed (a wrong number is worse than none).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import Bounds, LinearConstraint, milp

FloatArray = NDArray[np.float64]
NONE = -1  # no detection in that camera

MISS = 25.0  # cost of leaving a marker without evidence (chi-square units)
RAY_PENALTY = MISS / 2  # a ray leaves the marker unseen in the other camera: half a miss


class Option(NamedTuple):
    """One way a marker can be explained in this pair of frames.

    Attributes:
        marker: index of the marker (row of the predictions).
        det_a: detection index in camera a, or ``NONE``.
        det_b: detection index in camera b, or ``NONE``.
        cost: chi-square cost (below ``MISS``).
        xyz: (3,) the option's 3D point [m] (for a ray: the point on it nearest the
            prediction).
    """

    marker: int
    det_a: int
    det_b: int
    cost: float
    xyz: FloatArray


@dataclass(frozen=True)
class Choice:
    """What the assignment gave one marker.

    Attributes:
        option: the option taken.
        sure_a, sure_b: whether no rival detection comes close in that camera.
    """

    option: Option
    sure_a: bool
    sure_b: bool


def assign(options: list[Option], caps_a: NDArray[np.int64], caps_b: NDArray[np.int64],
           margin: float) -> dict[int, Choice]:
    """The best joint choice of options (marker index -> :class:`Choice`).

    Args:
        options: every marker's options (those below ``MISS``).
        caps_a, caps_b: how many markers each detection of camera a and b may serve.
        margin: cost margin below which a rival detection makes a marker ambiguous.
    """
    out: dict[int, Choice] = {}
    for group in competing_groups(options):
        chosen = solve(group, caps_a, caps_b)
        base = total(chosen)
        for opt in chosen:
            sure = [True, True]
            for cam, det in ((0, opt.det_a), (1, opt.det_b)):
                if det == NONE:
                    continue
                if not rivalled(group, opt.marker, cam, det):
                    continue  # no option could take the spot or give the marker another
                rest = [o for o in group if not (o.marker == opt.marker
                                                 and (o.det_a, o.det_b)[cam] == det)]
                alt = solve(rest, caps_a, caps_b)
                if total(alt) - base < margin and rivalled(alt, opt.marker, cam, det):
                    sure[cam] = False
            out[opt.marker] = Choice(opt, sure[0], sure[1])
    return out


def rivalled(alt: list[Option], marker: int, cam: int, det: int) -> bool:
    """Whether, in the alternative choice (or among the options) ``alt``, ``marker`` takes
    another detection of camera ``cam`` (0: a, 1: b) than ``det``, or another marker takes
    ``det``: either way the identity of that camera's spot is in doubt."""
    for o in alt:
        mine = (o.det_a, o.det_b)[cam]
        if o.marker == marker and mine not in (NONE, det):
            return True
        if o.marker != marker and mine == det:
            return True
    return False


def total(chosen: list[Option]) -> float:
    """Objective of a choice: its cost against leaving every marker without evidence."""
    return float(sum(o.cost - MISS for o in chosen))


def competing_groups(options: list[Option]) -> list[list[Option]]:
    """The options split into groups of markers that share no detection with other groups
    (union-find over markers and detections), each group in input order."""
    parent: dict[tuple[int, int], tuple[int, int]] = {}

    def find(x: tuple[int, int]) -> tuple[int, int]:
        parent.setdefault(x, x)
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    for o in options:
        root = find((0, o.marker))
        for key in ((1, o.det_a), (2, o.det_b)):
            if key[1] != NONE:
                parent[find(key)] = root
    groups: dict[tuple[int, int], list[Option]] = {}
    for o in options:
        groups.setdefault(find((0, o.marker)), []).append(o)
    return list(groups.values())


def solve(options: list[Option], caps_a: NDArray[np.int64], caps_b: NDArray[np.int64],
          ) -> list[Option]:
    """The options of one group taken by the exact optimum (each marker at most once, each
    detection at most its cap); a single marker simply takes its cheapest option."""
    if not options:
        return []
    markers = sorted({o.marker for o in options})
    if len(markers) == 1:
        return [min(options, key=lambda o: (o.cost, o.det_a, o.det_b))]
    rows: dict[tuple[int, int], int] = {}
    ub: list[float] = []
    entries: list[tuple[int, int]] = []
    for j, o in enumerate(options):
        for key, cap in (((0, o.marker), 1.0),
                         ((1, o.det_a), float(caps_a[o.det_a]) if o.det_a != NONE else 0.0),
                         ((2, o.det_b), float(caps_b[o.det_b]) if o.det_b != NONE else 0.0)):
            if key[0] > 0 and key[1] == NONE:
                continue
            if key not in rows:
                rows[key] = len(ub)
                ub.append(cap)
            entries.append((rows[key], j))
    a = np.zeros((len(ub), len(options)))
    for r, j in entries:
        a[r, j] = 1.0
    cost = np.array([o.cost - MISS for o in options])
    res = milp(cost, constraints=LinearConstraint(a, -np.inf, np.array(ub)),
               integrality=np.ones(len(options)), bounds=Bounds(0, 1))
    if res.x is None:
        return []
    return [o for o, x in zip(options, res.x, strict=True) if x > 0.5]
