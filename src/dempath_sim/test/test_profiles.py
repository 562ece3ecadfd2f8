"""Tool kinematics against the constant-acceleration formulas and the paper's two profiles."""

from __future__ import annotations

import numpy as np
import pytest

from dempath_sim.scene.profiles import PAPER_1_5MS, PAPER_1MS, PRESETS, SpeedProfile, ToolPath


def test_profile_1_matches_paper() -> None:
    """Profile 1: 2 s and 1000 mm of acceleration, 3 s steady, 7 s and 5000 mm in total."""
    p = PAPER_1MS
    assert p.acceleration_time_s == pytest.approx(2.0)
    assert p.acceleration_distance_m == pytest.approx(1.0)
    assert p.steady_time_s == pytest.approx(3.0)
    assert p.deceleration_distance_m == pytest.approx(1.0)
    assert p.total_time_s == pytest.approx(7.0)
    assert p.total_distance_m == pytest.approx(5.0)


def test_profile_2_matches_paper() -> None:
    """Profile 2: 1.36 s over 1023 mm, 1.97 s steady over 2954.55 mm, 4.7 s, 5000 mm."""
    p = PAPER_1_5MS
    assert p.acceleration_distance_m == pytest.approx(1.023, abs=5e-4)
    assert p.acceleration_time_s == pytest.approx(1.36, abs=5e-3)
    assert p.steady_time_s == pytest.approx(1.97, abs=5e-3)
    assert p.total_time_s == pytest.approx(4.7, abs=0.01)
    assert p.total_distance_m == pytest.approx(5.0, abs=1e-3)


@pytest.mark.parametrize('name', sorted(PRESETS))
def test_distance_is_integral_of_velocity(name: str) -> None:
    """s(t) equals the integral of v(t) and v(t) its derivative, for every preset."""
    p = PRESETS[name]
    t = np.linspace(0.0, p.total_time_s, 20001)
    v = p.velocity(t)
    s_int = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t))])
    np.testing.assert_allclose(p.distance(t), s_int, atol=1e-6 * p.total_distance_m + 1e-9)
    assert v.max() == pytest.approx(p.speed_m_s)
    assert p.distance(p.total_time_s + 1.0) == pytest.approx(p.total_distance_m)


def test_formulas_in_each_phase() -> None:
    """s = a t^2 / 2 while accelerating, linear when steady, symmetric when decelerating."""
    p = SpeedProfile(2.0, 4.0, 2.0, 1.0)
    assert p.distance(0.25) == pytest.approx(0.5 * 4.0 * 0.25**2)
    assert p.distance(0.5 + 0.2) == pytest.approx(0.5 + 2.0 * 0.2)
    t_dec = 0.5 + 0.5 + 0.3
    assert p.distance(t_dec) == pytest.approx(1.5 + 2.0 * 0.3 - 0.5 * 2.0 * 0.3**2)
    assert p.velocity(t_dec) == pytest.approx(2.0 - 2.0 * 0.3)


def test_time_at_distance_inverts_distance() -> None:
    """time_at_distance is the inverse of distance in all three phases."""
    for s in (0.1, 0.9, 1.0, 2.5, 4.2, 4.999):
        t = PAPER_1MS.time_at_distance(s)
        assert PAPER_1MS.distance(t) == pytest.approx(s, abs=1e-9)
    with pytest.raises(ValueError, match='outside'):
        PAPER_1MS.time_at_distance(6.0)


def test_from_distances_and_scaling() -> None:
    """from_distances gives a = v^2/(2d); scaling keeps distances and divides times."""
    p = SpeedProfile.from_distances(1.5, 1.023, 2.95455, 1.023)
    assert p.acceleration_m_s2 == pytest.approx(1.5**2 / 2.046)
    fast = PAPER_1MS.scaled(1.5)
    assert fast.total_distance_m == pytest.approx(PAPER_1MS.total_distance_m)
    assert fast.total_time_s == pytest.approx(PAPER_1MS.total_time_s / 1.5)
    with pytest.raises(ValueError, match='speed_m_s'):
        SpeedProfile(0.0, 1.0, 1.0, 1.0)


def test_tool_path_offset() -> None:
    """A path started part-way moves from its start point with the profile's speed there."""
    path = ToolPath(PAPER_1MS, (0.0, -0.184, 0.3), offset_m=0.25)
    pos, vel = path.pose_at(0.0)
    np.testing.assert_allclose(pos, [0.0, -0.184, 0.3])
    assert vel[2] == pytest.approx(np.sqrt(2 * 0.5 * 0.25))
    t = path.time_to_travel(1.2)
    assert path.pose_at(t)[0][2] == pytest.approx(1.5)
