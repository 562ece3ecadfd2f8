"""Each numbered marker's image path over the whole pass, smoothed as much as the pass's own
residuals say (a Kalman smoother whose amount leave-one-out prediction chooses).

A marker moves with the sand: at 50 frames per second its image path is smooth except where
the tine strikes it, and its detected centre scatters about that path by the image's noise.
That scatter, paired with the other camera's, is part of the 3D error (the error budget of
session 24: the 2D centre is the largest term on every look but the shaken one). How much to
smooth depends on the look: under noise and JPEG 60 a fixed 5-frame fit took 9 % off the 3D
RMS, on clean renders the same fit rounded the tine's accelerations off and added 1-5 %. So
the amount is chosen by the data, per pass:

- the model (each image axis of each camera's track apart): a constant-velocity path driven
  by white acceleration noise of spectral density ``q`` [px^2/s^3], measured with white
  noise of variance ``r`` [px^2]; its Rauch-Tung-Striebel smoother (Rauch, Tung & Striebel
  1965) is the cubic smoothing spline (Wahba 1978);
- the ratio ``q / r`` is chosen on the grid ``RATIOS`` by the leave-one-out prediction error
  of all the pass's numbered points (for a linear smoother the residual with the point left
  out is its residual over ``1 - h``, ``h`` its weight in its own smoothed value, the
  smoothed variance over ``r``; Wahba 1990, 4.2). Cross-validation, not the likelihood: the
  sand's motion is not the model's Gaussian (long rests, then a strike), and the likelihood
  chose 10-1000 times too much smoothing on the tuning looks (pooled 3D RMS 1.70 -> 1.68 mm
  against 1.64);
- never across a gap: a run ends where a marker is not numbered in a frame (or the camera
  dropped a frame), and the next run starts afresh (its velocity unknown);
- never across a jump: the noise ``r`` is measured from the chosen ratio's leave-one-out
  residuals (their median, so that strikes do not inflate it), and the smoother runs again
  with every point whose innovation is beyond ``JUMP_SIGMA`` standard deviations (a strike,
  a wrong number, a neighbour's blob) starting a new run, so that it pulls no neighbour;
- only the centres move, never a number; runs shorter than ``MIN_RUN`` stay as measured.

It runs on the whole pass at ``flush``, so the same frames give the same output whatever their
arrival, and the node graph still equals the offline path.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dempath_recon.tracking.records import PixelFrame

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

RATIOS: FloatArray = np.asarray(np.logspace(4, 8, 9), np.float64)
# the grid of q / r [1/s^3], half a decade apart: the smoother's equivalent window,
# about (r / q)^(1/4) s, runs from 100 ms (1e4: 5 frames either side) to 10 ms (1e8: no
# smoothing); the tuning looks chose 3e5-1e7 (a grid of 1e2-1e9 chose nothing outside)
JUMP_SIGMA = 5.0  # an innovation beyond this many standard deviations starts a new run
# (Gaussian: 6e-7 of good points)
MIN_RUN = 3  # a run needs this many points to be smoothed (two give no residual)
MIN_R_PX2 = 0.05 ** 2  # floor of the measured noise [px^2] (a render without noise)
BIG = 1e12  # the unknown velocity's prior variance at a run's start [r / s^2]
CHI2_MEDIAN = 0.455  # the median of a chi-square with one degree of freedom (turns the median
# squared residual into a variance)


def centre_grid(frames: list[PixelFrame],
                ) -> tuple[FloatArray, FloatArray, dict[tuple[int, int], tuple[int, int]]]:
    """Both cameras' numbered points on one frame x column grid: ``(centres (n, k) px, NaN
    where not numbered; stamps (n, k) s, NaN where the camera has no n-th frame; (frame,
    row) -> (n-th frame, column u))``. Each camera's frames in stamp order give the rows;
    columns 2j, 2j+1 are one (camera, marker)'s u and v (a number given twice in one frame:
    the first)."""
    cams = sorted({f.camera for f in frames})
    orders = [sorted((i for i, f in enumerate(frames) if f.camera == c),
                     key=lambda i: frames[i].stamp_s) for c in cams]
    cols: dict[tuple[str, int], int] = {}
    for order in orders:
        for i in order:
            for m in frames[i].markers.tolist():
                if m >= 0:
                    cols.setdefault((frames[i].camera, m), 2 * len(cols))
    n = max((len(o) for o in orders), default=0)
    z = np.full((n, 2 * len(cols)), np.nan)
    stamps = np.full((n, 2 * len(cols)), np.nan)
    where: dict[tuple[int, int], tuple[int, int]] = {}
    for order in orders:
        for t, i in enumerate(order):
            f = frames[i]
            for k, m in enumerate(f.markers.tolist()):
                if m < 0:
                    continue
                j = cols[(f.camera, m)]
                stamps[t, j:j + 2] = f.stamp_s
                if np.isnan(z[t, j]):
                    z[t, j:j + 2] = f.uv[k]
                    where[(i, k)] = (t, j)
    return z, stamps, where


class _Filtered:
    """The Kalman filter's forward pass at each ratio (``r`` the unit of variance): filtered
    means and covariances, the predictions' means and covariances, and where each run starts.
    Arrays (g, n, k)."""

    def __init__(self, z: FloatArray, dt: FloatArray, ratios: FloatArray, fps: float,
                 jump_r: float | None) -> None:
        g, (n, k) = len(ratios), z.shape
        lam = ratios[:, None]
        shape = (g, n, k)
        self.m0, self.m1 = np.full(shape, np.nan), np.full(shape, np.nan)
        self.p00, self.p01, self.p11 = (np.full(shape, np.nan) for _ in range(3))
        self.q00, self.q01, self.q11 = (np.full(shape, np.nan) for _ in range(3))
        self.a0, self.a1 = np.full(shape, np.nan), np.full(shape, np.nan)
        self.start = np.zeros(shape, bool)
        for t in range(n):
            seen = np.broadcast_to(np.isfinite(z[t]), (g, k))
            going = np.zeros((g, k), bool)
            if t > 0:
                h = np.where(dt[t] <= 1.5 / fps, dt[t], np.nan)  # a dropped frame: a gap
                a0 = self.m0[:, t - 1] + h * self.m1[:, t - 1]
                a1 = self.m1[:, t - 1]
                q00 = (self.p00[:, t - 1] + 2 * h * self.p01[:, t - 1]
                       + h * h * self.p11[:, t - 1] + lam * h ** 3 / 3)
                q01 = self.p01[:, t - 1] + h * self.p11[:, t - 1] + lam * h * h / 2
                q11 = self.p11[:, t - 1] + lam * h
                s = q00 + 1.0
                nu = z[t] - a0
                going = seen & np.isfinite(a0)
                if jump_r is not None:
                    going &= nu ** 2 <= JUMP_SIGMA ** 2 * s * jump_r
                k0, k1 = q00 / s, q01 / s
                self.a0[:, t], self.a1[:, t] = a0, a1
                self.q00[:, t], self.q01[:, t], self.q11[:, t] = q00, q01, q11
                self.m0[:, t] = np.where(going, a0 + k0 * nu, np.nan)
                self.m1[:, t] = np.where(going, a1 + k1 * nu, np.nan)
                self.p00[:, t] = np.where(going, q00 - k0 * q00, np.nan)
                self.p01[:, t] = np.where(going, q01 - k0 * q01, np.nan)
                self.p11[:, t] = np.where(going, q11 - k1 * q01, np.nan)
            fresh = seen & ~going  # a run starts: the position measured, the velocity unknown
            self.m0[:, t] = np.where(fresh, z[t], self.m0[:, t])
            self.m1[:, t] = np.where(fresh, 0.0, self.m1[:, t])
            self.p00[:, t] = np.where(fresh, 1.0, self.p00[:, t])
            self.p01[:, t] = np.where(fresh, 0.0, self.p01[:, t])
            self.p11[:, t] = np.where(fresh, BIG, self.p11[:, t])
            self.start[:, t] = fresh


def _smoothed(f: _Filtered, dt: FloatArray) -> tuple[FloatArray, FloatArray, BoolArray]:
    """The RTS smoother at every ratio: positions (g, n, k) px, their variances in units of
    r (g, n, k) (the hat matrix's diagonal: a point's weight in its own smoothed value), and
    where a run of at least ``MIN_RUN`` points gives them (g, n, k)."""
    s0, s1 = f.m0.copy(), f.m1.copy()
    v00, v01, v11 = f.p00.copy(), f.p01.copy(), f.p11.copy()
    linked = ~f.start & np.isfinite(f.m0)  # point t continues the run of point t - 1
    for t in range(f.m0.shape[1] - 2, -1, -1):
        nxt = linked[:, t + 1]
        if not nxt.any():
            continue
        h = np.where(np.isfinite(dt[t + 1]), dt[t + 1], np.nan)  # NaN: no run goes on
        q00, q01, q11 = f.q00[:, t + 1], f.q01[:, t + 1], f.q11[:, t + 1]
        det = np.where(nxt, q00 * q11 - q01 * q01, 1.0)
        # the smoother's gain C = P F^T Q^-1, with F = [[1, h], [0, 1]]
        b00, b01 = f.p00[:, t] + h * f.p01[:, t], f.p01[:, t]
        b10, b11 = f.p01[:, t] + h * f.p11[:, t], f.p11[:, t]
        c00, c01 = (b00 * q11 - b01 * q01) / det, (b01 * q00 - b00 * q01) / det
        c10, c11 = (b10 * q11 - b11 * q01) / det, (b11 * q00 - b10 * q01) / det
        d0, d1 = s0[:, t + 1] - f.a0[:, t + 1], s1[:, t + 1] - f.a1[:, t + 1]
        s0[:, t] = np.where(nxt, f.m0[:, t] + c00 * d0 + c01 * d1, s0[:, t])
        s1[:, t] = np.where(nxt, f.m1[:, t] + c10 * d0 + c11 * d1, s1[:, t])
        # V_t = P_t + C (V_t+1 - Q_t+1) C^T
        e00, e01, e11 = v00[:, t + 1] - q00, v01[:, t + 1] - q01, v11[:, t + 1] - q11
        v00[:, t] = np.where(nxt, f.p00[:, t] + c00 * (c00 * e00 + c01 * e01)
                             + c01 * (c00 * e01 + c01 * e11), v00[:, t])
        v01[:, t] = np.where(nxt, f.p01[:, t] + c00 * (c10 * e00 + c11 * e01)
                             + c01 * (c10 * e01 + c11 * e11), v01[:, t])
        v11[:, t] = np.where(nxt, f.p11[:, t] + c10 * (c10 * e00 + c11 * e01)
                             + c11 * (c10 * e01 + c11 * e11), v11[:, t])
    return s0, v00, _long_runs(f.start, np.isfinite(f.m0))


def _long_runs(start: BoolArray, seen: BoolArray) -> BoolArray:
    """(g, n, k) the points in runs of at least ``MIN_RUN`` points."""
    g, n, k = start.shape
    run = np.cumsum(start | ~seen, axis=1)  # a run's id within its column
    run = run + (n + 1) * np.arange(g * k).reshape(g, 1, k)  # unique over columns
    length = np.bincount(run.ravel())
    return np.asarray((length[run] >= MIN_RUN) & seen, bool)


def _loo_score(z: FloatArray, s: FloatArray, hat: FloatArray, ok: BoolArray) -> FloatArray:
    """(g,) each ratio's leave-one-out prediction error over the points it smooths,
    ``sum ((z - s) / (1 - hat))^2`` (exact for a linear smoother; Wahba 1990, 4.2)."""
    loo = (z[None] - s) / np.maximum(1.0 - hat, 1e-6)
    return np.asarray((np.where(ok, loo, 0.0) ** 2).sum(axis=(1, 2)), np.float64)


def smooth_grid(z: FloatArray, stamps: FloatArray, fps: float,
                ) -> tuple[FloatArray, BoolArray, float, float]:
    """A grid of centres (n, k) px at stamps (n, k) s smoothed: ``(smoothed (n, k), where
    smoothed (n, k), the chosen q / r [1/s^3], the noise r [px^2])``. The ratio is chosen by
    leave-one-out prediction over the grid ``RATIOS``, the noise r measured from that ratio's
    leave-one-out residuals (their median: a strike does not inflate it), then the smoother
    run again at that ratio with the jump test at that r."""
    dt = np.vstack([np.full((1, z.shape[1]), np.inf), np.diff(stamps, axis=0)])
    dt = np.where(np.isfinite(dt), dt, np.inf)
    first = _Filtered(z, dt, RATIOS, fps, None)
    s, hat, ok = _smoothed(first, dt)
    g = int(np.argmin(_loo_score(z, s, hat, ok)))
    loo = ((z - s[g]) / np.maximum(1.0 - hat[g], 1e-6))[ok[g]]
    r = max(float(np.median(loo ** 2)) / CHI2_MEDIAN, MIN_R_PX2) if len(loo) else MIN_R_PX2
    second = _Filtered(z, dt, RATIOS[g:g + 1], fps, r)
    s, _, ok = _smoothed(second, dt)
    return s[0], ok[0], float(RATIOS[g]), r


def smooth_paths(frames: list[PixelFrame], fps: float) -> list[PixelFrame]:
    """The frames with every numbered point's centre replaced by its smoothed path's (see the
    module's docstring); unnumbered points, numbers and the frames' order unchanged."""
    z, stamps, where = centre_grid(frames)
    if not z.size:
        return frames
    s, ok, _, _ = smooth_grid(z, stamps, fps)
    new = [f.uv.copy() for f in frames]
    for (i, row), (t, j) in where.items():
        if ok[t, j] and ok[t, j + 1]:
            new[i][row] = s[t, j:j + 2]
    return [f if np.array_equal(u, f.uv) else f._replace(uv=u)
            for f, u in zip(frames, new, strict=True)]
