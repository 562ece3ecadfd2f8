"""Progress of a running recalibration: one record per iteration, handed to callbacks.

The loop (:mod:`dempath_diagnose.recalibration.loop`) emits a :class:`Progress` through a plain
callback; the command line prints it with an ETA, and ``--publish-progress`` also hands it to
the progress node (``dempath_diagnose.nodes.progress_publisher``), which publishes
``dempath_msgs/RecalibrationProgress`` for Foxglove and the recorder. No ROS here.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from enum import IntEnum
from typing import TextIO


class State(IntEnum):
    """Where the recalibration is (the message's constants have the same values)."""

    RUNNING = 0
    FINISHED = 1
    INTERRUPTED = 2
    FAILED = 3


@dataclass(frozen=True)
class Progress:
    """One iteration of a recalibration.

    Attributes:
        effect: The candidate fitted.
        iteration: 0 for the scene as it is, then 1, 2, ...
        error: d^2 of the real runs at this iteration (inf for a failed run).
        best_error: Lowest d^2 so far.
        floor: What the model gives over packing seeds: the median of the last like-for-like
            d^2 band the loop judged by (the mean of chi^2_k before one, or without one).
        floor_significant: d^2 above this is significantly above the floor (that band's top,
            or chi^2_k's 95 % quantile).
        names: ``effect.parameter`` of each fitted strength.
        values: The strengths at this iteration (SI units, as ``names``).
        simulations: Simulations used so far.
        eta_s: Estimated time left [s] (0 when finished).
        state: RUNNING, then FINISHED, INTERRUPTED or FAILED.
        detail: The stop reason or the failure ('' while running).
        like_for_like: Whether ``floor`` comes from a like-for-like band (the model at its
            strengths played as the measurement); False: the nominal chi^2_k, shown as such.
    """

    effect: str
    iteration: int
    error: float
    best_error: float
    floor: float
    floor_significant: float
    names: tuple[str, ...]
    values: tuple[float, ...]
    simulations: int
    eta_s: float
    state: State = State.RUNNING
    detail: str = ''
    like_for_like: bool = False


Callback = Callable[[Progress], None]


def fan_out(callbacks: Sequence[Callback]) -> Callback:
    """One callback that calls each of ``callbacks`` in turn."""
    def call(p: Progress) -> None:
        for cb in callbacks:
            cb(p)
    return call


def progress_line(p: Progress) -> str:
    """One line for the terminal: iteration, values, error beside the floor, ETA."""
    values = ', '.join(f'{n} {v:.4g}' for n, v in zip(p.names, p.values, strict=True))
    err = 'failed' if math.isinf(p.error) else f'{p.error:.1f}'
    tail = f'ETA {p.eta_s:.0f} s' if p.state is State.RUNNING else p.state.name.lower()
    detail = f' ({p.detail})' if p.detail else ''
    floor = (f'floor band median {p.floor:.1f}, top {p.floor_significant:.1f}'
             if p.like_for_like else
             f'no like-for-like floor yet; nominal chi^2 mean {p.floor:.1f}')
    return (f'recalibrate {p.effect} iteration {p.iteration}: {values}; error d^2 {err} '
            f'(best {p.best_error:.1f}; {floor}); {p.simulations} simulations; '
            f'{tail}{detail}')


def printer(stream: TextIO | None = None) -> Callback:
    """A callback printing :func:`progress_line` to ``stream`` (stderr by default)."""
    def call(p: Progress) -> None:
        print(progress_line(p), file=stream or sys.stderr, flush=True)
    return call
