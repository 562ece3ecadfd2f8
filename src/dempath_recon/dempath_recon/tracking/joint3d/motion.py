"""Each marker's 3D state and its prediction: markers ride on sand pushed by the tool.

A marker moves with the sand around it: its speed is bounded (the tool's, ``max_speed_m_s``)
and so is its acceleration (sand ahead of a tine is pushed up to the tool's speed over several
frames, not in one). The state is a position and a velocity, predicted at constant velocity
with an uncertainty that grows as ``a_max t^2 / 2`` with the time since the last 3D fix (the
largest change of velocity the sand can give it), never beyond ``max_speed_m_s t``. A marker
no camera placed in a frame takes the mean velocity of its placed neighbours (within
``NEIGHBOUR_M``): neighbouring markers move nearly rigidly with the bed, so a hidden marker is
carried with them rather than left behind or sent on alone. The filter is an alpha-beta filter
(Kalata, "The tracking index", IEEE Trans. AES 20(2), 1984): cheap, deterministic, and enough
for a 50 FPS stream where the 3D fix (about 1 mm) is much better than the prediction.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class MotionModel:
    """The sand's limits and the filter's gains.

    Attributes:
        max_speed_m_s: fastest a marker moves [m/s].
        max_accel_m_s2: largest acceleration the sand gives a marker [m/s^2].
        fix_sigma_m: uncertainty of a marker's position just after a 3D fix [m].
        max_sigma_m: cap of the prediction's uncertainty [m] (beyond it the marker is lost
            and only the grid or its neighbours can place it).
        alpha, beta: the filter's position and velocity gains.
    """

    max_speed_m_s: float = 2.0
    max_accel_m_s2: float = 25.0
    fix_sigma_m: float = 0.0015
    max_sigma_m: float = 0.03
    alpha: float = 0.9
    beta: float = 0.5

    def __post_init__(self) -> None:
        for name in ('max_speed_m_s', 'max_accel_m_s2', 'fix_sigma_m', 'max_sigma_m'):
            if not getattr(self, name) > 0:
                msg = f'{name}: must be > 0, got {getattr(self, name)!r}'
                raise ValueError(msg)
        for name in ('alpha', 'beta'):
            if not 0 < getattr(self, name) <= 1:
                msg = f'{name}: must be in (0, 1], got {getattr(self, name)!r}'
                raise ValueError(msg)


@dataclass
class MarkerState:
    """One marker's 3D state.

    Attributes:
        xyz: (3,) position at ``stamp_s`` [m] (world frame).
        velocity: (3,) [m/s].
        stamp_s: when ``xyz`` held [s].
        fixed_s: stamp of the last 3D fix (a consistent pair) [s].
        sigma0_m: uncertainty at ``fixed_s`` [m] (larger before the first fix: grid only).
        fixes: 3D fixes so far.
    """

    xyz: FloatArray
    velocity: FloatArray = field(default_factory=lambda: np.zeros(3))
    stamp_s: float = 0.0
    fixed_s: float = 0.0
    sigma0_m: float = 0.0015
    fixes: int = 0


NEIGHBOUR_M = 0.075  # markers this close move nearly together with the bed (1.5 pitches) [m]
CARRY_SHARE = 0.2  # a carried marker's uncertainty grows by this share of the distance carried
CARRY_FLOOR_M = 0.0005  # ... plus this a frame [m]


def predict(model: MotionModel, state: MarkerState, stamp_s: float) -> tuple[FloatArray, float]:
    """``((3,) m, sigma m)``: where the marker is at ``stamp_s`` and how sure that is."""
    dt = stamp_s - state.stamp_s
    since = max(stamp_s - state.fixed_s, 0.0)
    grow = min(0.5 * model.max_accel_m_s2 * since ** 2, model.max_speed_m_s * since)
    sigma = min(float(np.hypot(state.sigma0_m, grow)), model.max_sigma_m)
    return np.asarray(state.xyz + state.velocity * dt, np.float64), max(sigma, state.sigma0_m)


def fix(model: MotionModel, state: MarkerState, stamp_s: float, xyz: FloatArray) -> None:
    """Update the state with a 3D fix (a consistent pair) at ``stamp_s``: alpha-beta filter,
    the velocity clipped to ``max_speed_m_s``."""
    pred, _ = predict(model, state, stamp_s)
    dt = stamp_s - state.stamp_s
    resid = np.asarray(xyz, np.float64) - pred
    state.xyz = pred + model.alpha * resid
    if state.fixes > 0 and dt > 0:
        state.velocity = clip_speed(state.velocity + model.beta * resid / dt,
                                    model.max_speed_m_s)
    state.stamp_s = state.fixed_s = stamp_s
    state.sigma0_m = model.fix_sigma_m
    state.fixes += 1


def nudge(state: MarkerState, stamp_s: float, xyz: FloatArray) -> None:
    """Update the state with one camera's ray: ``xyz`` is the point on that line of sight
    nearest the prediction. The position follows; the velocity does not (a ray leaves the
    depth unknown), and the uncertainty keeps the value of the last fix: a camera that still
    sees the marker keeps it from drifting across its line of sight (the prediction's
    growth restarts from this stamp), but does not make it surer than the fix did."""
    state.xyz = np.asarray(xyz, np.float64)
    state.stamp_s = state.fixed_s = stamp_s


def carry_with_neighbours(model: MotionModel, states: dict[int, MarkerState], placed: set[int],
                          stamp_s: float) -> None:
    """Carry each marker not placed at ``stamp_s`` with the mean velocity of its placed
    neighbours within ``NEIGHBOUR_M`` (none near: it keeps its own state and its uncertainty
    grows from its last fix). A carried marker's uncertainty grows by ``CARRY_SHARE`` of the
    distance carried plus ``CARRY_FLOOR_M`` a frame instead of by the sand's largest
    acceleration: its neighbours' fixes say how the bed around it moved (still, before the
    tool comes: then it has not moved either)."""
    moving = [m for m in placed if m in states]
    if not moving:
        return
    pos = np.array([states[m].xyz for m in moving])
    vel = np.array([states[m].velocity for m in moving])
    for m, st in states.items():
        if m in placed:
            continue
        near = np.linalg.norm(pos - st.xyz, axis=1) < NEIGHBOUR_M
        if not near.any():
            continue
        _, sigma = predict(model, st, st.stamp_s)  # its uncertainty when last placed
        st.velocity = clip_speed(vel[near].mean(axis=0), model.max_speed_m_s)
        step = float(np.linalg.norm(st.velocity)) * max(stamp_s - st.stamp_s, 0.0)
        st.xyz = st.xyz + st.velocity * (stamp_s - st.stamp_s)
        st.sigma0_m = min(float(np.hypot(sigma, CARRY_SHARE * step + CARRY_FLOOR_M)),
                          model.max_sigma_m)
        st.stamp_s = st.fixed_s = stamp_s


def clip_speed(velocity: FloatArray, max_speed_m_s: float) -> FloatArray:
    """(3,) m/s: ``velocity`` shortened to at most ``max_speed_m_s``."""
    speed = float(np.linalg.norm(velocity))
    return velocity if speed <= max_speed_m_s else velocity * (max_speed_m_s / speed)
