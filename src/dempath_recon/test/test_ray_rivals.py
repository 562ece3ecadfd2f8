"""A spot one camera alone shows at the grid fit (``tracking.ray_rivals``): numbered by its image
grid only when no other free marker rests within half a pitch of its line of sight.

The scene of heldout27 ``T287_asis``, projected through the twin's true cameras: marker 12 sunk
9 mm and pushed 6 mm toward 13 before the first frame, the side seeing neither 12 nor 13, the
front not 13. The front's spot of 12 lies on its line of sight through 13's grid point; its
image grid numbers it 13 for the whole pass.
"""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from projected import GRID15, numbers_given, run_scene

from dempath_recon.tracking.associate import MarkerGrid
from dempath_recon.tracking.ray_rivals import line_distances
from dempath_recon.tracking.stereo import StereoTrackConfig

FLOW = np.array([0.0, 0.0, 0.0005])  # the bed's slow creep along the travel [m/frame]
SUNK = np.array([0.0, -0.009, 0.006])  # marker 12's displacement before the first frame [m]
FRAMES = 10


def test_line_distances_are_the_perpendicular_distances(rig) -> None:
    """A point on a spot's line of sight is 0 m from it; one moved across the line by 5 mm
    (perpendicular to the line) is 5 mm from it."""
    cam = rig.cameras[1]
    p = np.array([0.01, 0.0, 0.02])
    centre = -np.asarray(cam.R).T @ np.asarray(cam.t).ravel()
    sight = (p - centre) / np.linalg.norm(p - centre)
    across = np.cross(sight, [0.0, 1.0, 0.0])
    across /= np.linalg.norm(across)
    d = line_distances(cam, cam.project(p[None]), np.array([p, p + 0.005 * across,
                                                           p + 0.1 * sight]))
    assert d.shape == (1, 3)
    assert d[0] == pytest.approx([0.0, 0.005, 0.0], abs=2e-5)


def _front_numbers_of_twelve(rig, rivals: bool) -> list[int]:
    """The number the front gave marker 12's spot in each of its frames."""
    start = np.array(GRID15)
    start[11] += SUNK
    config = replace(StereoTrackConfig(grid=MarkerGrid(layout_m=GRID15)), ray_rivals=rivals)

    def frame(k: int) -> tuple[list, list]:
        pts = start + k * FLOW
        return ([p for m, p in enumerate(pts, 1) if m not in (12, 13)],
                [p for m, p in enumerate(pts, 1) if m != 13])

    out = run_scene(rig, config, map(frame, range(FRAMES)))[0]
    return numbers_given(out, rig.cameras[1], lambda k: start[11] + k * FLOW)


def test_without_the_step_the_image_grid_numbers_the_sunk_marker_wrong(rig) -> None:
    """Off, the front's image grid gives marker 12's spot 13 in every frame (the switch)."""
    assert set(_front_numbers_of_twelve(rig, rivals=False)) == {13}


def test_a_spot_with_a_rival_on_its_line_of_sight_is_never_given_the_rival(rig) -> None:
    """On, 13's grid point and 12's both lie within half a pitch of the spot's line of sight
    and nothing rules either out: the spot never goes out as 13."""
    got = _front_numbers_of_twelve(rig, rivals=True)
    assert 13 not in got
    assert set(got) <= {-1, 12}
