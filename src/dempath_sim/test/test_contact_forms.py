"""LIGGGHTS 3.8's contact forms (``contact_forms: liggghts``) against dempath's: how springs are
carried into a turned tangent plane, the rolling limit under tension, the lever arm of plane
contacts, and how scenes select the forms."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

import dempath_sim
from dempath_sim.engine import Engine
from dempath_sim.engine.laws.hertz_mindlin import hertz_mindlin, hertz_mindlin_constants
from dempath_sim.engine.laws.rolling_epsd2 import rolling_epsd2
from dempath_sim.engine.materials import Interaction, Material
from dempath_sim.engine.params import SimParams
from dempath_sim.engine.state import SimState
from dempath_sim.engine.walls import Plane
from dempath_sim.runs.bed import packing_key
from dempath_sim.scene import SceneError, bundled_scene, scene_from_dict
from dempath_sim.validation.cross_engine import same_physics

SCENES = Path(dempath_sim.__file__).resolve().parent / 'data' / 'scenes'
E_STAR, G_STAR, BETA = 1.0e6, 4.0e5, 0.35  # Pa, Pa, - (soft sand, e ~ 0.3)
R_EFF, M_EFF, DT = 2e-3, 3e-5, 1e-5  # m, kg, s


def _spring_after(forms: float, spring0: tuple[float, float, float]) -> np.ndarray:
    """The tangential spring [m] after one step at rest of a contact with normal +Y."""
    hist = np.array([spring0])
    hertz_mindlin(1e-4, R_EFF, M_EFF, *hertz_mindlin_constants(E_STAR, G_STAR, BETA), 0.5, 0.5,
                  0.0, 1.0, 0.0, 0.0, 0.0, 0.0, hist, 0, DT, 1.0, forms)
    return hist[0]


def test_tangential_spring_turned_with_or_without_its_length() -> None:
    """A spring half along the new normal keeps its length (dempath) or loses that part."""
    np.testing.assert_allclose(_spring_after(0.0, (1e-6, 1e-6, 0.0)), [math.sqrt(2) * 1e-6, 0, 0])
    np.testing.assert_allclose(_spring_after(1.0, (1e-6, 1e-6, 0.0)), [1e-6, 0, 0])


def _rolling(forms: float, f_n: float, m0: tuple[float, float, float]) -> np.ndarray:
    """Rolling torque [N m] on a contact with normal +Y and no relative rotation."""
    hist = np.array([m0])
    return np.array(rolling_epsd2(R_EFF, 1e3, f_n, 0.3, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0,
                                  hist, 0, DT, forms))


def test_rolling_spring_carried_and_limited_on_abs_normal_force() -> None:
    """LIGGGHTS carries the rolling spring unturned and limits it by mu_r R* |F_n| even when
    F_n is tensile; dempath turns it and holds no torque under tension."""
    m0 = (1e-7, 1e-7, 0.0)
    np.testing.assert_allclose(_rolling(0.0, 1.0, m0), [math.sqrt(2) * 1e-7, 0, 0])
    np.testing.assert_allclose(_rolling(1.0, 1.0, m0), m0)
    np.testing.assert_allclose(_rolling(0.0, -1.0, m0), [0, 0, 0])
    np.testing.assert_allclose(_rolling(1.0, -1e-3, m0), m0)  # limit 6e-7 N m > |m0|
    limited = _rolling(1.0, -1e-4, m0)  # limit 0.3 * 2e-3 * 1e-4 = 6e-8 N m
    assert np.linalg.norm(limited) == pytest.approx(0.3 * R_EFF * 1e-4, rel=1e-12)


def _spin_on_floor(forms: str, r: float, delta: float,
                   rolling: float = 0.0) -> tuple[float, float]:
    """(F_x [N], torque_z [N m]) on a sphere spinning about Z in place on a floor, one step."""
    sand = Material('sand', 1734.0, 1.7e6, 0.25)
    inter = Interaction(0.3, 0.7, 0.7, rolling)
    params = SimParams(materials=(sand,), interactions={(0, 0): inter},
                       dt=1e-6, gravity=(0.0, 0.0, 0.0), contact_forms=forms)
    state = SimState.from_spheres(np.array([[0.0, r - delta, 0.0]]), np.array([r]), 0, params)
    state.angular_velocities[0, 2] = 0.2  # rad/s: a slow spin, the contact sticks
    engine = Engine(params, [Plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0), 0)])
    engine.run(state, 1)
    force, torque = engine.forces
    return float(force[0, 0]), float(torque[0, 2])


def test_plane_contact_lever_arm() -> None:
    """A sphere spinning in place on a floor: the friction torque is lever x force with the
    lever arm r - delta (dempath) or r - delta / 2 (LIGGGHTS), and the slip velocity, hence
    the sticking friction force, scales with the same lever arm."""
    r, delta = 0.005, 2e-4
    fx_d, tz_d = _spin_on_floor('dempath', r, delta)
    fx_l, tz_l = _spin_on_floor('liggghts', r, delta)
    assert fx_d < 0.0  # opposes the slip omega x (-lever n) = +lever omega along X
    assert tz_d == pytest.approx((r - delta) * fx_d, rel=1e-9)
    assert tz_l == pytest.approx((r - delta / 2) * fx_l, rel=1e-9)
    assert fx_l / fx_d == pytest.approx((r - delta / 2) / (r - delta), rel=1e-4)


def test_plane_contact_rolling_spin_scale() -> None:
    """With rolling resistance the rolling torque (total torque less lever x force) on a wall
    grows with the spin scaled by (r - delta / 2) / (r - delta) in LIGGGHTS' forms, as its
    epsd2 takes the wall spin, and with the plain spin in dempath's."""
    r, delta = 0.005, 2e-4
    fx_d, tz_d = _spin_on_floor('dempath', r, delta, rolling=0.3)
    fx_l, tz_l = _spin_on_floor('liggghts', r, delta, rolling=0.3)
    m_d = tz_d - (r - delta) * fx_d
    m_l = tz_l - (r - delta / 2) * fx_l
    assert m_d < 0.0  # resists the spin
    assert m_l / m_d == pytest.approx((r - delta / 2) / (r - delta), rel=1e-4)


@pytest.mark.parametrize(('key', 'default', 'other', 'typo'),
                         [('coulomb_limit', 'total', 'spring', 'springs'),
                          ('contact_forms', 'dempath', 'liggghts', 'ligghts')])
def test_scene_options_and_same_physics(key: str, default: str, other: str, typo: str) -> None:
    """sim.<key> is read and checked, changes the packing key when not at its default, and
    same_physics sets LIGGGHTS' choice."""
    scene = bundled_scene('tiny')
    model = scene.physics_model()
    assert getattr(scene.sim, key) == default
    raw = yaml.safe_load((SCENES / 'tiny.yaml').read_text())
    raw['sim'][key] = other
    changed = scene_from_dict(raw)
    assert getattr(changed.sim, key) == other
    assert packing_key(changed, model) != packing_key(scene, model)
    assert getattr(same_physics(scene).sim, key) == other
    raw['sim'][key] = typo
    with pytest.raises(SceneError, match=rf"sim\.{key}.*did you mean '{other}'"):
        scene_from_dict(raw)
