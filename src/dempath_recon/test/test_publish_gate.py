"""The publication gate (``tracking.publish_gate``): a pair whose 3D point jumps away from its
neighbours' motion is withheld; a marker that keeps moving unlike them goes out again."""

from __future__ import annotations

import numpy as np

from dempath_recon.tracking.publish_gate import GateConfig, PublicationGate
from dempath_recon.tracking.records import PixelFrame

DT = 0.02  # frame period [s]
OFFSET = 0.003  # the front camera exposes this much after the side one [s]
PITCH = 0.025  # [m]
GRID = np.array([(x, 0.0, z) for z in (-PITCH, 0.0, PITCH) for x in (-PITCH, 0.0, PITCH)])
IDS = np.arange(1, 10, dtype=np.int32)  # marker 5 in the middle
VELOCITY = np.array([0.0, 0.0, 0.1])  # the sand's motion [m/s]


def frames(rig, moved: dict[int, np.ndarray], n: int = 16):
    """Side and front frames of the nine markers moving together; ``moved[k]``: (9, 3) m
    positions given to the numbers at instant k instead."""
    cams = {c.name: c for c in rig.cameras}
    out = []
    for k in range(n):
        for name, t in (('cam_side', k * DT), ('cam_front', k * DT + OFFSET)):
            xyz = moved.get(k, GRID + VELOCITY * k * DT) + VELOCITY * (t - k * DT)
            out.append(PixelFrame(name, t, IDS.copy(), cams[name].project(xyz),
                                  np.ones(len(IDS)), ()))
    return cams, out


def published(rig, moved: dict[int, np.ndarray], config: GateConfig) -> dict[tuple[int, str],
                                                                             bool]:
    """Whether marker 5 went out numbered, per (instant, camera)."""
    cams, given = frames(rig, moved)
    gate = PublicationGate(cams, 1 / DT, config)
    out = {}
    for f in given:
        checked, _ = gate.check(f)
        out[(round(f.stamp_s / DT - 0.1), f.camera)] = bool((checked.markers == 5).any())
    return out


def test_number_moved_to_a_neighbours_spot_is_withheld(rig) -> None:
    """At instants 8-9 both cameras give number 5 to a spot a pitch aside (a consistent pair,
    the wrong marker): both pairs are withheld (the side's at instant 8 for its residual with
    the front's right point before it, the others for their jump); before and after, marker 5
    goes out (but for the side at instant 10, paired with the front's wrong point). With the
    gate wide (the rule off) the wrong pairs go out."""
    moved = {}
    for k in (8, 9):
        xyz = GRID + VELOCITY * k * DT
        xyz[4] = xyz[4] + np.array([PITCH, 0.0, 0.0])
        moved[k] = xyz
    out = published(rig, moved, GateConfig())
    assert not any(out[(k, c)] for k in (8, 9) for c in ('cam_side', 'cam_front'))
    assert all(out[(k, c)] for k in (*range(8), *range(11, 16))
               for c in ('cam_side', 'cam_front'))
    assert out[(10, 'cam_front')]
    wide = published(rig, moved, GateConfig(gate_m=1.0, residual_px=1e3))
    assert all(wide.values())


def test_marker_moving_unlike_its_neighbours_goes_out_again(rig) -> None:
    """From instant 6 marker 5 lies 20 mm aside and stays there (the sand under it slumped):
    its first pairs are withheld (the side's at instant 6, paired with the front's point before
    the slump, lies within the gate), then the smooth run becomes its history and it goes out
    again within three instants. Without the reseed it stays withheld until the history is
    stale."""
    moved = {}
    for k in range(6, 16):
        xyz = GRID + VELOCITY * k * DT
        xyz[4] = xyz[4] + np.array([0.02, 0.0, 0.0])
        moved[k] = xyz
    out = published(rig, moved, GateConfig())
    assert not out[(6, 'cam_front')]
    assert all(out[(k, c)] for k in range(10, 16) for c in ('cam_side', 'cam_front'))
    stuck = published(rig, moved, GateConfig(reseed_s=10.0))
    assert not any(stuck[(k, c)] for k in range(7, 16) for c in ('cam_side', 'cam_front'))


def test_lone_marker_struck_by_the_tool_goes_out(rig) -> None:
    """A marker with no neighbour within ``neighbour_m`` that the tool strikes (0.1 m/s, then
    1.0 m/s from instant 10: 18 mm a frame off its own velocity) goes out at every frame: with
    no neighbour the gate does not predict it (a prediction by its own velocity, the rule
    this replaced, withheld it)."""
    cams = {c.name: c for c in rig.cameras}
    gate = PublicationGate(cams, 1 / DT, GateConfig())
    start = np.array([0.0, 0.0, -0.05])

    def at(t: float) -> np.ndarray:
        return start + np.array([0.0, 0.0, 0.1 * t + 0.9 * max(t - 10 * DT, 0.0)])

    went_out = []
    for k in range(20):
        for name, t in (('cam_side', k * DT), ('cam_front', k * DT + OFFSET)):
            checked, _ = gate.check(PixelFrame(name, t, np.array([1], np.int32),
                                               cams[name].project(at(t)[None]), np.ones(1), ()))
            went_out.append(int(checked.markers[0]) == 1)
    assert all(went_out)
