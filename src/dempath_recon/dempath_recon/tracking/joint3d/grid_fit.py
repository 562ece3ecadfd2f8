"""The markers' first numbers: the known grid fitted to a frame's 3D candidates.

The markers are laid in a known grid (``MarkerGrid``: rows x columns, 50 mm pitch), but where
the grid lies in the calibrated frame is known only roughly (its height above the calibration
board, small offsets of each marker from its grid point). The fit looks for the 3D translation
that puts most grid points near a candidate point: every candidate-minus-grid-point difference
is a hypothesis, scored by ``sum_g max(0, 1 - (d_g / gate)^2)`` over the grid points (d_g: the
distance from grid point g to its nearest candidate), then refined by the mean residual of the
matched points. The grid's place on the surface (X lateral, Z travel) is known to within a
fraction of a pitch (the experiment lays it there; only its height, Y, is free): a hypothesis
farther than ``max_offset_m`` across the surface is no fit. A regular grid shifted by one pitch
still matches most of itself, so the fit is refused (the tracker waits for the next frame)
when the best fit shifted by one pitch along any of the grid's directions, still within that
bound, scores within ``min_gap`` of it: a guess there would number every marker wrong for the
whole pass.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dempath_recon.tracking.joint3d.candidates import PairCandidates

FloatArray = NDArray[np.float64]


def fit_score(grid_xyz: FloatArray, cand_xyz: FloatArray, offsets: FloatArray,
              gate_m: float) -> FloatArray:
    """(h,) score of each offset (h, 3) m: grid points (n, 3) m moved by it against the
    candidates (p, 3) m."""
    moved = grid_xyz[None, :, :] + offsets[:, None, :]  # (h, n, 3)
    d = np.linalg.norm(moved[:, :, None, :] - cand_xyz[None, None, :, :], axis=3).min(axis=2)
    return np.asarray(np.clip(1.0 - (d / gate_m) ** 2, 0.0, None).sum(axis=1), np.float64)


def across(offsets: FloatArray) -> FloatArray:
    """(h,) m: the size of each offset (h, 3) m across the surface (its X and Z parts)."""
    return np.asarray(np.hypot(offsets[..., 0], offsets[..., 2]), np.float64)


def pitch_shifts(grid_xyz: FloatArray) -> FloatArray:
    """(s, 3) m: the grid's one-pitch shifts, both signs (each grid point's vector to its
    nearest neighbour, rounded to 0.1 mm and deduplicated)."""
    if len(grid_xyz) < 2:
        return np.zeros((0, 3))
    d = np.linalg.norm(grid_xyz[:, None] - grid_xyz[None], axis=2)
    np.fill_diagonal(d, np.inf)
    steps = grid_xyz[np.argmin(d, axis=1)] - grid_xyz
    both = np.round(np.concatenate([steps, -steps]), 4)
    return np.asarray(np.unique(both, axis=0), np.float64)


def exclusive_score(grid_xyz: FloatArray, cand: PairCandidates, offset: FloatArray,
                    gate_m: float) -> float:
    """Score of one offset (3,) m where each detection serves one grid point at most: the
    (grid point, candidate) matches are taken nearest first, skipping any whose grid point or
    either detection is already taken. A false pair (one marker's detection with another's on
    its epipolar line, a point where no marker is) then cannot add to a fit beside the right
    pair of the same detection."""
    d = np.linalg.norm(grid_xyz[:, None] + offset - cand.xyz[None], axis=2)  # (n, p)
    gi, pj = np.nonzero(d < gate_m)
    order = np.lexsort((pj, gi, d[gi, pj]))
    used_g, used_a, used_b = set(), set(), set()
    score = 0.0
    for k in order.tolist():
        g, p = int(gi[k]), int(pj[k])
        a, b = int(cand.ia[p]), int(cand.ib[p])
        if g in used_g or a in used_a or b in used_b:
            continue
        used_g.add(g)
        used_a.add(a)
        used_b.add(b)
        score += 1.0 - (float(d[g, p]) / gate_m) ** 2
    return score


def fit_grid(grid_xyz: FloatArray, cand: PairCandidates, gate_m: float, min_matched: int,
             min_gap: float, max_offset_m: float) -> tuple[FloatArray | None, str]:
    """The grid's offset (3,) m, or None and why not.

    Args:
        grid_xyz: (n, 3) grid points [m].
        cand: the frame's candidate pairs (3D points and their detections).
        gate_m: distance within which a candidate matches a grid point [m].
        min_matched: fewest grid points that must find a candidate.
        min_gap: smallest score lead (``exclusive_score``) over the best one-pitch-shifted
            fit.
        max_offset_m: largest offset across the surface (X, Z) a fit may have [m].
    """
    cand_xyz = cand.xyz
    if len(cand_xyz) < min_matched:
        return None, f'{len(cand_xyz)} candidate points, need {min_matched}'
    every: FloatArray = (cand_xyz[:, None, :] - grid_xyz[None, :, :]).reshape(-1, 3)
    hyp = every[across(every) <= max_offset_m]
    if len(hyp) == 0:
        return None, f'no fit within {max_offset_m:.3f} m of the laid grid'
    scores = fit_score(grid_xyz, cand_xyz, hyp, gate_m)
    best = hyp[int(np.argmax(scores))]
    moved = grid_xyz + best
    d = np.linalg.norm(moved[:, None] - cand_xyz[None], axis=2)
    near = d.min(axis=1) < gate_m
    if near.sum() < min_matched:
        return None, f'{int(near.sum())} grid points matched, need {min_matched}'
    resid = cand_xyz[np.argmin(d, axis=1)] - moved
    best = best + resid[near].mean(axis=0)
    score = exclusive_score(grid_xyz, cand, best, gate_m)
    steps = pitch_shifts(grid_xyz)
    shifts = steps[across(best + steps) <= max_offset_m]
    if len(shifts):
        rival = max(exclusive_score(grid_xyz, cand, best + s, gate_m) for s in shifts)
        if score - rival < min_gap:
            return None, (f'a fit shifted by one pitch scores {rival:.2f} against '
                          f'{score:.2f}')
    return np.asarray(best, np.float64), f'grid fitted ({int(near.sum())} points, score ' \
        f'{score:.2f})'
