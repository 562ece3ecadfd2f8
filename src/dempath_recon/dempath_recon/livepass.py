"""Measured passes on a live rig: when a pass starts and ends, from the tool's motion or events.

On a tractor the cameras run all the time; a measured pass is the stretch in which the tool moves
through the marked bed. :class:`PassGate` decides it from either source, one sample at a time:

- ``run_event``: an upstream ``RunEvent`` (a button, the tractor's controller, a player) says
  STARTED and FINISHED (or ABORTED);
- ``tool_motion``: the tool's position along Z (travel) [m] from its pose or odometry; the pass
  starts once the speed has stayed above ``start_speed`` for ``hold_s`` and ends once it has
  stayed below ``stop_speed`` for ``hold_s`` (hysteresis, so that a jolt neither starts nor ends
  a pass). The speed is the finite difference of consecutive samples.

The paper's passes accelerate at 0.5-1.1 m/s^2 to 1.0 or 1.5 m/s (sec. 2.3): with the defaults
(start above 0.3 m/s, stop below 0.1 m/s, held 0.2 s) a pass starts about 0.5 s into the
acceleration and ends about 0.2 s after the tool has nearly stopped.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum
from typing import NamedTuple


class Trigger(Enum):
    """What starts and ends a pass."""

    RUN_EVENT = 'run_event'
    TOOL_MOTION = 'tool_motion'


class PassChange(NamedTuple):
    """A pass started (``started`` True) or ended, at ``stamp_s`` [s], with a reason."""

    pass_id: int
    started: bool
    stamp_s: float
    detail: str


@dataclass(frozen=True)
class PassConfig:
    """Settings of :class:`PassGate`.

    Attributes:
        trigger: ``run_event`` or ``tool_motion``.
        start_speed: Tool speed that starts a pass once held [m/s].
        stop_speed: Tool speed that ends it once held [m/s] (below ``start_speed``).
        hold_s: How long a speed must hold [s].
    """

    trigger: str = Trigger.TOOL_MOTION.value
    start_speed: float = 0.3
    stop_speed: float = 0.1
    hold_s: float = 0.2

    def __post_init__(self) -> None:
        checks = {'trigger': self.trigger in {t.value for t in Trigger},
                  'start_speed': self.start_speed > 0,
                  'stop_speed': 0 <= self.stop_speed < self.start_speed,
                  'hold_s': self.hold_s >= 0}
        for name, ok in checks.items():
            if not ok:
                msg = f'{name}: out of range, got {getattr(self, name)!r}'
                raise ValueError(msg)


class PassGate:
    """Streaming pass detector: feed events or tool positions, get :class:`PassChange` s."""

    def __init__(self, config: PassConfig) -> None:
        self.config = config
        self.trigger = Trigger(config.trigger)
        self.active = False
        self.count = 0
        self._last: tuple[float, float] | None = None  # (t, z) of the previous sample
        self._since: float | None = None  # when the speed crossed the threshold
        self._aborted = False  # a pass was aborted: no new one until the tool has stopped

    def abort(self) -> None:
        """End the current pass as incomplete; the next starts only after the tool stops."""
        self.active = False
        self._aborted = self.trigger is Trigger.TOOL_MOTION

    def on_event(self, started: bool, stamp_s: float, detail: str = '') -> PassChange | None:
        """An upstream RunEvent: STARTED (True) or FINISHED/ABORTED (False)."""
        if self.trigger is not Trigger.RUN_EVENT or started == self.active:
            return None
        return self._change(started, stamp_s, detail or ('run event STARTED' if started
                                                         else 'run event FINISHED'))

    def on_tool(self, stamp_s: float, z_m: float) -> PassChange | None:
        """A tool position along the travel direction Z [m] at ``stamp_s`` [s]."""
        if self.trigger is not Trigger.TOOL_MOTION:
            return None
        last, self._last = self._last, (stamp_s, z_m)
        if last is None or stamp_s <= last[0]:
            return None
        speed = abs(z_m - last[1]) / (stamp_s - last[0])
        if self._aborted:
            self._aborted = speed >= self.config.stop_speed
            return None
        crossing = speed < self.config.stop_speed if self.active \
            else speed > self.config.start_speed
        if not crossing or not math.isfinite(speed):
            self._since = None
            return None
        self._since = last[0] if self._since is None else self._since
        if stamp_s - self._since < self.config.hold_s:
            return None
        self._since = None
        word = 'below' if self.active else 'above'
        limit = self.config.stop_speed if self.active else self.config.start_speed
        return self._change(not self.active, stamp_s,
                            f'tool speed {speed:.2f} m/s {word} {limit} m/s for '
                            f'{self.config.hold_s} s')

    def _change(self, started: bool, stamp_s: float, detail: str) -> PassChange:
        self.active = started
        if started:
            self.count += 1
        return PassChange(self.count, started, stamp_s, detail)


class CameraWatch:
    """Notices a camera whose frames stop arriving (a cable, a driver, a full disk).

    Args:
        cameras: The camera names expected.
        timeout_s: Longest gap between two frames of a camera before it counts as stopped [s].
    """

    def __init__(self, cameras: tuple[str, ...], timeout_s: float) -> None:
        if not timeout_s > 0:
            msg = f'camera_timeout_s: must be > 0, got {timeout_s!r}'
            raise ValueError(msg)
        self.timeout_s = timeout_s
        self.last: dict[str, float | None] = dict.fromkeys(cameras)

    def seen(self, camera: str, now_s: float) -> None:
        """A frame (or its pixel points) of ``camera`` arrived at ``now_s`` [s]."""
        if camera in self.last:
            self.last[camera] = now_s

    def stopped(self, now_s: float, since_s: float) -> list[str]:
        """Cameras with no frame for ``timeout_s``, counting from ``since_s`` at the latest."""
        return [camera for camera, t in self.last.items()
                if now_s - max(t if t is not None else since_s, since_s) > self.timeout_s]
