"""A thin measurement: too few markers, or none on the tool axis or beside it, to name an effect.

The verdict of a thin measurement is ``inconclusive`` whatever the probabilities, and its notes
say how many markers naming an effect needs.
"""

from __future__ import annotations

from dataclasses import replace

from dempath_diagnose.decision.statistics import Layout
from dempath_diagnose.decision.verdict import Decision

MIN_MARKERS = 3  # fewer markers than this cannot tell candidates apart (see thin_measurement)


def thin_measurement(layout: Layout) -> str:
    """Why a measurement is too thin to name an effect, or ''.

    The candidates differ in how markers on the tool axis and beside it move (heave and lift on
    the axis, outward push beside it), and a group statistic of one particle carries that
    particle's own chaotic spread. So a diagnosis needs at least :data:`MIN_MARKERS` markers,
    at least one on the tool axis and one beside the tool; with fewer its verdict is
    ``inconclusive`` whatever the probabilities (:func:`thin_decision`).
    """
    axis = sum(len(g.members) for g in layout.groups if g.side == 0)
    beside = sum(len(g.members) for g in layout.groups if g.side != 0)
    n = len(layout.markers)
    if n >= MIN_MARKERS and axis and beside:
        return ''
    return (f'thin measurement: {n} marker{"s" if n != 1 else ""} ({axis} on the tool axis, '
            f'{beside} beside it); naming an effect needs at least {MIN_MARKERS} markers with '
            'at least one on the axis and one beside the tool')


def thin_decision(decision: Decision, layout: Layout) -> Decision:
    """``decision`` made ``inconclusive`` (every model remaining, the reason in its notes)
    when the measurement is thin; unchanged otherwise."""
    note = thin_measurement(layout)
    if not note:
        return decision
    remaining = [decision.baseline.name, *(f.name for f in decision.ranking)]
    return replace(decision, verdict='inconclusive', remaining=remaining,
                   notes=[*decision.notes, note])
