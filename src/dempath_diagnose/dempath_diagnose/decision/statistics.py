"""Group statistics of a pass: what an effect moves more than chaos does (issue 13).

A single marker's path is one sample of a chaotic bed (~25 mm between packings), so the
diagnosis compares *group* statistics: markers are grouped by where they start relative to the
tool (on its axis, beside it left / right, and by depth when they lie at several depths), the
pass is cut into ``n_windows`` equal time windows, and per group and window the statistic is the
time-average of the markers' mean displacement along three axes: lateral *outward* (X, signed
away from the tool axis), vertical (Y) and forward (Z, travel). With a measured force, the mean
draft (-Fz) per window while the tool moves is added.

The model's counterpart of a measured marker is every library particle whose start lies in a
cube (the scene's ``markers.cube_size_m``) centred on the marker's measured start: the paper's
Cube candidates, for any layout. The prediction for the marker is the bed's displacement *at the
marker's start*: a least-squares plane through the cube's particles (each window-mean feature
linear in the particle's start offset from the marker), read at offset zero. The plain cube mean
would be the field at the cube's centroid, which for a marker on the surface lies half a cube
deeper (a surface cube is half empty) and in a displacement field that falls steeply with depth
and with distance from the tool: a bias that also scales an effect's response (on
``reduced_1ms``, hidden tool speeds of x1.5 and x0.7 were fitted at 1.58 and 0.61). The
measured marker is one particle, so its scatter about that plane (``sampling_cov``, divided by
the markers in the group squared) is part of the prediction's uncertainty, beside the spread
over packing seeds (see :mod:`dempath_diagnose.decision.emulator`). Cubes with fewer than
``FIELD_MIN_MEMBERS`` particles fall back to the mean.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from dempath_diagnose.library.counterparts import cube_members
from dempath_diagnose.records import F64, Measurement, PassRecord

AXES = ('lateral_out', 'vertical', 'forward')
SAMPLES_PER_WINDOW = 6  # interpolation points per window for the time-averages
FIELD_MIN_MEMBERS = 12  # particles a cube needs for the plane (4 coefficients) to be read


@dataclass(frozen=True)
class Group:
    """Markers that share a position relative to the tool.

    Attributes:
        name: ``axis``, ``left`` or ``right``, with ``/deep`` for a lower depth band.
        members: Indices into the layout's markers.
        side: +1 (right, +X), -1 (left), 0 (on the axis): the sign of 'outward'.
    """

    name: str
    members: NDArray[np.intp]
    side: int


@dataclass(frozen=True)
class Layout:
    """Marker groups and time windows of one case (from the measured start positions).

    Attributes:
        markers: (m,) marker numbers.
        starts: (m, 3) start positions in the scene frame [m].
        groups: The marker groups.
        windows: (K, 2) start and end of each time window [s].
        sides: (m,) outward sign of each marker (0 on the axis: lateral is plain X).
        force_windows: Indices of the windows in which the tool still moves (force statistics).
        present: (m, K) True where the marker was measured over the whole window (None: every
            marker in every window). A group statistic averages the markers present in its
            window, in the measurement and in the model alike.
    """

    markers: NDArray[np.int64]
    starts: F64
    groups: tuple[Group, ...]
    windows: F64
    sides: NDArray[np.int64]
    force_windows: tuple[int, ...] = ()
    present: NDArray[np.bool_] | None = None

    def presence(self) -> NDArray[np.bool_]:
        """(m, K) presence of each marker in each window (all True when not given)."""
        if self.present is None:
            return np.ones((len(self.markers), len(self.windows)), bool)
        return self.present

    def group_count(self, group: Group, window: int) -> int:
        """Markers of ``group`` present in ``window`` (the group's size when none is: the
        model's statistic then stands for the whole group and the measured one is missing)."""
        n = int(self.presence()[group.members, window].sum())
        return n or len(group.members)

    def names(self, with_force: bool) -> list[str]:
        """Statistic names ``group:axis:wK`` (and ``force:draft:wK``), in vector order."""
        out = [f'{g.name}:{a}:w{k}' for g in self.groups for a in self._axes(g)
               for k in range(len(self.windows))]
        if with_force:
            out += [f'force:draft:w{k}' for k in self.force_windows]
        return out

    @staticmethod
    def _axes(group: Group) -> tuple[str, ...]:
        return AXES if group.side else AXES[1:]  # the axis group has no outward direction


def build_layout(markers: NDArray[np.int64], starts: F64, tool_x_m: float,
                 axis_half_width_m: float, end_s: float, tool_stop_s: float,
                 n_windows: int = 4, depth_band_m: float = 0.03,
                 measured: Measurement | None = None) -> Layout:
    """Group the markers and cut ``[0, end_s]`` into ``n_windows`` windows.

    Args:
        markers: (m,) marker numbers.
        starts: (m, 3) start positions, scene frame [m].
        tool_x_m: X of the tool axis [m].
        axis_half_width_m: Markers within this lateral distance of the axis are 'on the axis'.
        end_s: End of the measured pass [s].
        tool_stop_s: Time the tool stops [s] (force windows end there).
        n_windows: Number of time windows.
        depth_band_m: Markers deeper than the group's top by more than this form a deep group.
        measured: The measurement, whose samples say which marker is present in which window
            (None: every marker in every window).
    """
    dx = starts[:, 0] - tool_x_m
    sides = np.where(np.abs(dx) <= axis_half_width_m, 0, np.sign(dx)).astype(np.int64)
    groups = []
    for name, side in (('axis', 0), ('left', -1), ('right', 1)):
        members = np.flatnonzero(sides == side)
        if not len(members):
            continue
        y = starts[members, 1]
        deep = y < y.max() - depth_band_m
        for suffix, part in (('', members[~deep]), ('/deep', members[deep])):
            if len(part):
                groups.append(Group(name + suffix, part, side))
    edges = np.linspace(0.0, end_s, n_windows + 1)
    windows = np.column_stack([edges[:-1], edges[1:]])
    force = tuple(k for k in range(n_windows) if windows[k, 0] < tool_stop_s)
    present = window_presence(measured, windows) if measured is not None else None
    return Layout(markers, starts, tuple(groups), windows, sides, force, present)


def window_presence(meas: Measurement, windows: F64) -> NDArray[np.bool_]:
    """(m, K) True where a marker was measured over the whole window (every sample time of
    the window's time-average lies between its first and last measured sample)."""
    grid = _grid(windows)
    out = np.zeros((len(meas.markers), len(windows)), bool)
    for j in range(len(meas.markers)):
        ok = np.flatnonzero(np.isfinite(meas.positions[:, j]).all(1))
        if len(ok) < 2:
            continue
        first, last = meas.times[ok[0]], meas.times[ok[-1]]
        out[j] = np.all((grid >= first - 1e-9) & (grid <= last + 1e-9), axis=1)
    return out


def _grid(windows: F64) -> F64:
    """(K, S) sample times: S points at the centres of S equal sub-intervals of each window."""
    frac = (np.arange(SAMPLES_PER_WINDOW) + 0.5) / SAMPLES_PER_WINDOW
    return windows[:, :1] + (windows[:, 1:] - windows[:, :1]) * frac[None, :]


def window_means(times: F64, values: F64, windows: F64) -> F64:
    """Time-averages of ``values`` (nt, ...) over each window -> (K, ...), linear interpolation.

    Samples that are NaN make the window mean NaN only for that column.
    """
    grid = _grid(windows).ravel()
    j = np.searchsorted(times, grid, side='right') - 1
    j = j.clip(0, max(len(times) - 2, 0))
    t0, t1 = times[j], times[np.minimum(j + 1, len(times) - 1)]
    w = np.where(t1 > t0, (grid - t0) / np.where(t1 > t0, t1 - t0, 1.0), 0.0).clip(0.0, 1.0)
    shape = (len(grid),) + (1,) * (values.ndim - 1)
    v = values[j] * (1.0 - w.reshape(shape)) + values[np.minimum(j + 1, len(times) - 1)] * \
        w.reshape(shape)
    return np.asarray(v.reshape(len(windows), SAMPLES_PER_WINDOW, *values.shape[1:]).mean(1))


def oriented(displacement: F64, sides: NDArray[np.int64]) -> F64:
    """(..., m, 3) displacements [m] -> (..., m, 3) as (lateral outward, vertical, forward)."""
    sign = np.where(sides == 0, 1, sides).astype(np.float64)
    return np.stack([displacement[..., 0] * sign, displacement[..., 1], displacement[..., 2]],
                    axis=-1)


def marker_features(meas: Measurement, layout: Layout) -> F64:
    """(m, K, 3) window-mean displacements of each measured marker (lateral out, Y, Z) [m];
    NaN in the windows where the marker was not measured throughout."""
    out = np.full((len(layout.markers), len(layout.windows), 3), np.nan)
    present = layout.presence()
    for j in range(len(layout.markers)):
        ok = np.isfinite(meas.positions[:, j, 0])
        if ok.sum() < 2:
            continue
        d = meas.positions[ok, j] - layout.starts[j]
        out[j] = window_means(meas.times[ok], d, layout.windows)
        out[j, ~present[j]] = np.nan
    return oriented(out.transpose(1, 0, 2), layout.sides).transpose(1, 0, 2)


def force_features(times: F64, force: F64, layout: Layout) -> F64:
    """Mean draft -Fz [N] per force window."""
    if not layout.force_windows:
        return np.zeros(0)
    draft = -force[:, 2]
    means = window_means(times, draft, layout.windows)
    return np.asarray(means[list(layout.force_windows)])


def group_vector(features: F64, layout: Layout, masked: bool = False) -> F64:
    """Group statistics (vector order of :meth:`Layout.names`) from (m, K, 3) features [m].

    ``masked``: average only the markers present in each window (the model's side, so that it
    sees the measurement's samples); a group-window with no marker present keeps every member
    (its measured statistic is missing and is not compared).
    """
    out = []
    present = layout.presence()
    for g in layout.groups:
        f = features[g.members]
        if masked:
            use = present[g.members]  # (n, K)
            use = use | ~use.any(axis=0, keepdims=True)
            f = np.where(use[..., None], f, np.nan)
        mean = np.nanmean(f, axis=0)  # (K, 3)
        for a in Layout._axes(g):
            out.append(mean[:, AXES.index(a)])
    return np.concatenate(out) if out else np.zeros(0)


def measured_statistics(meas: Measurement, layout: Layout) -> tuple[F64, F64]:
    """The measured statistic vector and the per-marker features (m, K, 3)."""
    features = marker_features(meas, layout)
    y = group_vector(features, layout)
    if meas.has_force:
        y = np.concatenate([y, force_features(meas.force_times, meas.force, layout)])
    return y, features


@dataclass(frozen=True)
class ModelStatistics:
    """The statistics of one model pass for a layout.

    Attributes:
        vector: (k,) group statistics [m] (and draft [N] when with force).
        sampling_cov: (k, k) covariance of a measured group statistic that picks one particle
            per cube (within-cube spread over the group's markers squared).
        features: (m, K, 3) features per marker: the cube's field at its start [m].
        feature_var: (m, K, 3) one particle's variance about it per marker [m^2].
        members: (m,) model particles per cube.
    """

    vector: F64
    sampling_cov: F64
    features: F64
    feature_var: F64
    members: NDArray[np.int64]


def model_statistics(rec: PassRecord, layout: Layout, cube: tuple[float, float, float],
                     with_force: bool) -> ModelStatistics:
    """Group statistics of a library pass for ``layout`` (see the module docstring)."""
    start = rec.start
    members = cube_members(start, layout.starts, cube)
    disp = rec.positions.astype(np.float64) - start[None]
    m, k = len(layout.markers), len(layout.windows)
    feat, var = np.full((m, k, 3), np.nan), np.full((m, k, 3), np.nan)
    per_particle: list[F64] = []
    for j, idx in enumerate(members):
        if not len(idx):
            per_particle.append(np.zeros((0, k, 3)))
            continue
        f = window_means(rec.times, disp[:, idx], layout.windows).transpose(1, 0, 2)  # (p, K, 3)
        f[..., 0] *= layout.sides[j] or 1
        feat[j], var[j], scatter = local_field(f, start[idx] - layout.starts[j])
        per_particle.append(scatter)
    vector = group_vector(feat, layout, masked=True)
    cov = _sampling_cov(per_particle, layout, len(vector))
    if with_force:
        force = force_features(rec.force_times, rec.tool_force, layout)
        vector = np.concatenate([vector, force])
        cov = np.pad(cov, ((0, len(force)), (0, len(force))))
    return ModelStatistics(vector, cov, feat, var,
                           np.array([len(i) for i in members], np.int64))


def local_field(features: F64, offsets: F64) -> tuple[F64, F64, F64]:
    """The cube's displacement field read at the marker's start (see the module docstring).

    Args:
        features: (p, K, 3) window-mean features of the cube's particles.
        offsets: (p, 3) their start offsets from the marker's start [m].

    Returns:
        (K, 3) the field at offset zero, (K, 3) one particle's variance about it (residual
        scatter plus the read value's own variance), and (p, K, 3) the particles' deviations
        from the field, centred on the read value and scaled so that their covariance is one
        particle's (for :func:`_sampling_cov`).
    """
    ok = np.isfinite(features).all(axis=(1, 2)) & np.isfinite(offsets).all(axis=1)
    f, o = features[ok], offsets[ok]
    p = len(f)
    if p < FIELD_MIN_MEMBERS:
        return np.nanmean(features, axis=0), np.nanvar(features, axis=0), features
    design = np.column_stack([np.ones(p), o])
    flat = f.reshape(p, -1)
    coef, *_ = np.linalg.lstsq(design, flat, rcond=None)
    resid = flat - design @ coef
    dof = p - design.shape[1]
    scatter_var = np.sum(resid**2, axis=0) / dof
    read_var = scatter_var * float(np.linalg.pinv(design.T @ design)[0, 0])
    shape = f.shape[1:]
    centred = (coef[0] + resid * np.sqrt((p - 1) / dof)).reshape(f.shape)
    return (coef[0].reshape(shape), (scatter_var + read_var).reshape(shape), centred)


def _sampling_cov(per_particle: list[F64], layout: Layout, n: int) -> F64:
    """Block-diagonal covariance (one block per group) of one-particle-per-cube group means,
    each window's mean over the markers present in it."""
    cov = np.zeros((n, n))
    at = 0
    k = len(layout.windows)
    present = layout.presence()
    for g in layout.groups:
        axes = [AXES.index(a) for a in Layout._axes(g)]
        size = len(axes) * k
        block = np.zeros((size, size))
        use = present[g.members] | ~present[g.members].any(axis=0, keepdims=True)  # (n, K)
        count = np.tile(use.sum(axis=0), len(axes)).astype(np.float64)  # (size,)
        for j, member in zip(g.members, use, strict=True):
            f = per_particle[j]
            if len(f) >= 2:
                flat = f[:, :, axes].transpose(0, 2, 1).reshape(len(f), size)
                mask = np.tile(member, len(axes)).astype(np.float64)
                block += np.nan_to_num(np.cov(flat, rowvar=False)) * np.outer(mask, mask)
        cov[at:at + size, at:at + size] = block / np.outer(count, count)
        at += size
    return cov
