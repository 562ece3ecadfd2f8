"""Simulation parameters of the DEM engine: materials, pair interactions, gravity, time step.

`SimParams` is a frozen record validated in `__post_init__`. Materials are referred to by their
index in `SimParams.materials` (particles, walls and the tool alike); `interactions` maps an
index pair (i, j) to an `Interaction` and is symmetric (giving (i, j) also defines (j, i)).
Rolling resistance and cohesion are on for the engine when any interaction has a non-zero
coefficient (`rolling_enabled`, `cohesion_enabled`); 0 means off.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

from dempath_sim.engine.materials import Interaction, Material
from dempath_sim.errors import SimulationError

Vec3 = tuple[float, float, float]


def _finite_vec(name: str, value: Vec3) -> Vec3:
    vec = tuple(float(v) for v in value)
    if len(vec) != 3 or not all(math.isfinite(v) for v in vec):
        msg = f'SimParams.{name} must be 3 finite numbers, got {value!r}'
        raise ValueError(msg)
    return vec  # type: ignore[return-value]


COULOMB_LIMITS = ('total', 'spring')  # what the Coulomb limit bounds (see SimParams)
CONTACT_FORMS = ('dempath', 'liggghts')  # how contact springs and lever arms are carried
# Largest overlap / radius before the engine stops: a geometric guard, not a stability test (the
# engine stops unstable contacts by their own stable step, see engine/stability.py), and the one
# default of SimParams and of a scene's ``sim.max_overlap_fraction``. At a full radius a sphere's
# centre reaches the other surface (a wall contact would lose its side); soft sand (E = 1.7 MPa)
# legitimately reaches half a radius under a tool.
DEFAULT_MAX_OVERLAP_FRACTION = 1.0


@dataclass(frozen=True)
class SimParams:
    """Physical and numerical parameters of one simulation.

    Attributes:
        materials: All materials (particles, walls, tool); referred to by index.
        interactions: (i, j) -> Interaction for material indices i, j; symmetric.
        gravity: Gravity vector (3,) [m/s^2], along -Y by default.
        dt: Time step [s]; None = Rayleigh time step of the finest particle * rayleigh_safety.
        rayleigh_safety: Fraction of the Rayleigh time step used when dt is None [-].
        skin: Neighbour-list skin as a fraction of the smallest particle radius [-];
            the list is rebuilt when a particle has moved more than skin/2.
        domain_min: Lower corner (3,) of the domain box [m]; particles leaving it are removed.
        domain_max: Upper corner (3,) of the domain box [m].
        max_overlap_fraction: Largest overlap / radius accepted before SimulationError [-]
            (a geometric guard; unstable contacts are stopped by their stable step).
        coulomb_limit: ``'total'``: the Coulomb limit bounds the whole tangential force
            (spring + dashpot); ``'spring'``: it bounds the spring alone, as LIGGGHTS 3.8's
            ``tangential history`` does (used for like-for-like cross-engine checks).
        contact_forms: ``'dempath'``: tangential and rolling springs are turned into the new
            tangent plane with their length kept, the rolling limit uses max(F_n, 0) and a
            plane or tool contact acts at the surface (lever arm r - delta); ``'liggghts'``:
            LIGGGHTS 3.8's forms: the tangential spring loses its normal part, the rolling
            spring is carried unturned with its limit on |F_n|, and plane and tool contacts
            have the lever arm r - delta / 2 and grow the rolling spring with the spin scaled
            by (r - delta / 2) / (r - delta); a tool contact keeps its springs onto a coplanar
            neighbour face or along a shared edge only, not round a convex edge (for
            like-for-like cross-engine checks).
    """

    materials: tuple[Material, ...]
    interactions: Mapping[tuple[int, int], Interaction]
    gravity: Vec3 = (0.0, -9.81, 0.0)
    dt: float | None = None
    rayleigh_safety: float = 0.2
    skin: float = 0.6
    domain_min: Vec3 = (-1e3, -1e3, -1e3)
    domain_max: Vec3 = (1e3, 1e3, 1e3)
    max_overlap_fraction: float = DEFAULT_MAX_OVERLAP_FRACTION
    coulomb_limit: str = 'total'
    contact_forms: str = 'dempath'
    _table: dict[tuple[int, int], Interaction] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        """Validate every field; raise ValueError naming the field and its value."""
        if not self.materials or not all(isinstance(m, Material) for m in self.materials):
            msg = f'SimParams.materials must be a non-empty tuple of Material, ' \
                  f'got {self.materials!r}'
            raise ValueError(msg)
        object.__setattr__(self, 'materials', tuple(self.materials))
        object.__setattr__(self, '_table', self._symmetric_table())
        object.__setattr__(self, 'gravity', _finite_vec('gravity', self.gravity))
        object.__setattr__(self, 'domain_min', _finite_vec('domain_min', self.domain_min))
        object.__setattr__(self, 'domain_max', _finite_vec('domain_max', self.domain_max))
        if any(lo >= hi for lo, hi in zip(self.domain_min, self.domain_max, strict=True)):
            msg = f'SimParams.domain_min {self.domain_min!r} must be below domain_max ' \
                  f'{self.domain_max!r} on every axis'
            raise ValueError(msg)
        if self.dt is not None and not (math.isfinite(self.dt) and self.dt > 0):
            msg = f'SimParams.dt must be None or a finite number > 0, got {self.dt!r}'
            raise ValueError(msg)
        if self.coulomb_limit not in COULOMB_LIMITS:
            msg = f'SimParams.coulomb_limit must be one of {COULOMB_LIMITS}, ' \
                  f'got {self.coulomb_limit!r}'
            raise ValueError(msg)
        if self.contact_forms not in CONTACT_FORMS:
            msg = f'SimParams.contact_forms must be one of {CONTACT_FORMS}, ' \
                  f'got {self.contact_forms!r}'
            raise ValueError(msg)
        for name, lo, hi in (('rayleigh_safety', 1e-4, 1.0), ('skin', 0.01, 5.0),
                             ('max_overlap_fraction', 1e-4, 1.0)):
            value = getattr(self, name)
            if not (math.isfinite(value) and lo <= value <= hi):
                msg = f'SimParams.{name} must be in [{lo}, {hi}], got {value!r}'
                raise ValueError(msg)

    def _symmetric_table(self) -> dict[tuple[int, int], Interaction]:
        table: dict[tuple[int, int], Interaction] = {}
        n = len(self.materials)
        for (i, j), inter in dict(self.interactions).items():
            if not (0 <= i < n and 0 <= j < n):
                msg = f'SimParams.interactions key {(i, j)!r} is not a pair of material ' \
                      f'indices in [0, {n})'
                raise ValueError(msg)
            if not isinstance(inter, Interaction):
                msg = f'SimParams.interactions[{(i, j)!r}] must be an Interaction, got {inter!r}'
                raise ValueError(msg)
            other = table.get((j, i))
            if other is not None and other != inter and i != j:
                msg = f'SimParams.interactions {(i, j)!r} and {(j, i)!r} differ; give one'
                raise ValueError(msg)
            table[(i, j)] = table[(j, i)] = inter
        return table

    def interaction(self, i: int, j: int) -> Interaction:
        """Return the interaction of material indices i and j.

        Raises:
            SimulationError: The pair is not in `interactions`.
        """
        try:
            return self._table[(i, j)]
        except KeyError as err:
            names = (self.materials[i].name, self.materials[j].name)
            msg = f'SimParams.interactions has no entry for materials {(i, j)!r} {names!r}'
            raise SimulationError(msg) from err

    def has_interaction(self, i: int, j: int) -> bool:
        """Whether material indices i and j have an interaction."""
        return (i, j) in self._table

    def require_interactions(self, used: Sequence[int], others: Sequence[int] = ()) -> None:
        """Check that every pair among the materials ``used`` and each of them with each of
        ``others`` (walls, tool) has an interaction.

        Raises:
            SimulationError: Naming the first pair that has none.
        """
        for a in used:
            for b in (*used, *others):
                self.interaction(int(a), int(b))

    @property
    def rolling_enabled(self) -> bool:
        """Whether any pair has a rolling resistance coefficient > 0."""
        return any(x.rolling_resistance > 0 for x in self._table.values())

    @property
    def cohesion_enabled(self) -> bool:
        """Whether any pair has a cohesion energy density > 0."""
        return any(x.cohesion_energy_density > 0 for x in self._table.values())
