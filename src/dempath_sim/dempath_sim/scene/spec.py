"""Scene records: frozen dataclasses of a validated scene, and the reading of its effects.

The loader (`loader.py`) builds these records; `read_effects` lives here because
`SceneSpec.with_overrides` re-reads the effect settings, so this module imports nothing back
from the loader.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

from dempath_sim.effects import Effect, PhysicsModel, all_effects
from dempath_sim.effects.base import ContactPair
from dempath_sim.engine.params import DEFAULT_MAX_OVERLAP_FRACTION
from dempath_sim.errors import SceneError
from dempath_sim.scene import profiles
from dempath_sim.scene._reader import Reader


@dataclass(frozen=True)
class BinSpec:
    """Soil bin box [m]: X width, Z length (travel direction), Y height of the walls."""

    width_x_m: float
    length_z_m: float
    height_y_m: float


@dataclass(frozen=True)
class SizeDistribution:
    """Particle diameter distribution of a layer.

    ``mono``: every diameter equal to the layer's. ``uniform``: uniform in d (1 +- spread).
    ``discrete``: diameters [m] drawn with the given mass fractions (normalised).
    """

    kind: str = 'mono'
    spread: float = 0.0
    diameters_m: tuple[float, ...] = ()
    mass_fractions: tuple[float, ...] = ()


@dataclass(frozen=True)
class LayerSpec:
    """One horizontal layer of the bed (listed bottom to top)."""

    name: str
    diameter_m: float
    thickness_m: float
    distribution: SizeDistribution
    coarse_grained: bool = True  # whether the particle_size effect scales this layer


@dataclass(frozen=True)
class MaterialSpec:
    """Bulk properties of one solid; the particles' Young's modulus is an effect parameter."""

    density_kg_m3: float
    poisson_ratio: float
    youngs_modulus_pa: float | None = None


@dataclass(frozen=True)
class EffectSetting:
    """Whether an effect is on in the scene and its parameter values (SI)."""

    enabled: bool
    values: Mapping[str, float]


@dataclass(frozen=True)
class ToolSpec:
    """Tool mesh, placement and drive.

    Attributes:
        mesh: Path of the STL; the mesh's origin is the tool's reference point (the tip).
        scale: Uniform scale of the mesh [1] (e.g. 0.001 for a mesh in millimetres).
        depth_m: Working depth of the tip below the surface [m] (paper: 0.184).
        depth_reference: ``settled_surface`` (the measured surface after the fill) or
            ``nominal_surface`` (Y = 0, shifted by ``settling_offset_m``).
        settling_offset_m: Shift of the tool for gravitational settling with the nominal
            surface [m] (paper: -0.017, Sec. 2.6).
        x_m: Lateral position of the tool axis [m].
        start_z_m: Z of the tip at simulation time 0 [m].
        profile: The kinematic profile.
        profile_offset_m: Profile distance already travelled at time 0 [m].
        travel_m: Distance the tool moves in the simulation (active length) [m].
        placement: ``carve`` (remove the particles overlapping the tool's closed mesh, as a
            LIGGGHTS deck deletes them), ``slot`` (everything in its bounding box: a pre-cut
            slot) or ``poured`` (the bed poured and settled around the tool standing at its
            start, as LIGGGHTS users set a bin up; ``runs.bed.standing_tool``).
        settle_s: Re-settle of the bed with the tool in place and the run's own physics before
            the pass [s] (builds the contact history; 0 starts the pass at once).
    """

    mesh: Path
    scale: float
    depth_m: float
    depth_reference: str
    settling_offset_m: float
    x_m: float
    start_z_m: float
    profile: profiles.SpeedProfile
    profile_offset_m: float
    travel_m: float
    placement: str = 'carve'
    settle_s: float = 0.06


MARKER_PICKS = ('exposed', 'top')  # MarkerSpec.pick


@dataclass(frozen=True)
class MarkerSpec:
    """Marker grid (paper Sec. 2.1: 3 x 5, 50 mm, 1-5 on the tool axis) and candidate cube.

    Markers are numbered row by row: row 0 (on the tool axis, X = x_m) holds 1..columns in
    travel order, row r lies at X = x_m + r * side * spacing_x_m. ``pick``: which grain near a
    grid point is its marker (``runs.markers``): ``exposed`` (default), the nearest whose top
    lies within one diameter of the local surface; ``top``, the nearest whose centre lies within
    one radius of the highest centre there, as the hand-written LIGGGHTS decks pick surface
    grains (grains beside a tine move outward less the deeper they sit).
    """

    rows: int = 3
    columns: int = 5
    spacing_x_m: float = 0.05
    spacing_z_m: float = 0.05
    first_z_m: float = 0.0
    x_m: float = 0.0
    side: int = 1
    cube_size_m: tuple[float, float, float] = (0.03, 0.02, 0.01)
    pick: str = 'exposed'


@dataclass(frozen=True)
class FillSpec:
    """Pour and settle: target bulk density, settling criterion, cache use, or a given bed.

    ``friction_scale`` < 1 pours with less friction and rolling resistance (denser packing),
    then settles again with the full values. ``pour_solid_fraction``: the solid fraction of the
    random loose insertion (LIGGGHTS ``insert/pack`` ``volumefraction_region``). ``physics``:
    ``scene`` pours the bed with the scene file's own effects (runs that change effects reuse
    that bed and re-settle it with their own physics), ``run`` with the run's. ``packing``: a
    bed made elsewhere (LIGGGHTS data file, CSV x,y,z,d or npz) used instead of the pour.
    ``count``: how many grains are poured. ``volume`` (the default): the target solid fraction
    times the layers' nominal volume; as the wall layers and the rough top are looser than the
    interior the density is measured in, such a bed stands a few millimetres above the nominal
    surface. ``surface``: the number is scaled and the bed poured again until its settled
    surface lies at the nominal surface (Y = 0) within ``tolerance`` x the bed's thickness, as a
    lab fills its bin to a depth; the target density is then the interior's.
    """

    bulk_density_target_kg_m3: float | None = None
    tolerance: float = 0.02
    settle_speed_m_s: float = 0.02
    max_settle_time_s: float = 3.0
    cache: bool = True
    friction_scale: float = 1.0  # factor on friction and rolling resistance while pouring
    pour_solid_fraction: float = 0.35
    physics: str = 'scene'
    packing: Path | None = None
    count: str = 'volume'


FILL_COUNTS = ('volume', 'surface')  # FillSpec.count


@dataclass(frozen=True)
class OutputSpec:
    """Recording intervals [s] and whether candidates are recorded."""

    interval_s: float = 0.01
    snapshot_interval_s: float = 0.1
    candidates: bool = True


@dataclass(frozen=True)
class NumericsSpec:
    """Time step [s] (None: Rayleigh step x safety), its safety factor and the overlap limit.

    Soft particles (the paper's E = 1.7 MPa) overlap by about 10 % of their radius when the
    tool hits them at 1 m/s (Hertz: delta = (15 m v^2 / (16 E* R^0.5))^(2/5)), so the limit
    before the engine stops is higher than for stiff grains.
    """

    time_step_s: float | None = None
    rayleigh_safety: float = 0.2
    max_overlap_fraction: float = DEFAULT_MAX_OVERLAP_FRACTION
    coulomb_limit: str = 'total'  # 'total' (spring + dashpot) or 'spring' (LIGGGHTS 3.8)
    contact_forms: str = 'dempath'  # 'dempath' or 'liggghts' (see SimParams.contact_forms)
    sleep: bool = False  # grains at rest sleep during the pass (engine/sleep.py; native engine)
    sleep_scale: float = 1.0  # the sleep thresholds times this (SleepSettings.scaled)


@dataclass(frozen=True)
class SceneSpec:
    """A whole scene, validated. Build with :func:`load_scene` or :func:`scene_from_dict`."""

    name: str
    description: str
    seed: int
    bin: BinSpec
    layers: tuple[LayerSpec, ...]
    materials: Mapping[str, MaterialSpec]
    effects: Mapping[str, EffectSetting]
    tool: ToolSpec
    markers: MarkerSpec
    fill: FillSpec
    output: OutputSpec
    sim: NumericsSpec
    source: str = '<dict>'
    bed_effects: Mapping[str, EffectSetting] | None = None  # the file's (None: ``effects``)

    @property
    def bed_thickness_m(self) -> float:
        """Nominal thickness of the bed, the sum of the layers [m]."""
        return sum(layer.thickness_m for layer in self.layers)

    def is_enabled(self, effect: str) -> bool:
        """Whether ``effect`` is on in this scene."""
        return self.effects[effect].enabled

    def physics_model(self) -> PhysicsModel:
        """The scene's materials with every effect applied (on: its values; off: absent)."""
        model = base_model(self.materials)
        for name, effect in all_effects().items():
            setting = self.effects[name]
            model = (effect.apply(model, setting.values) if setting.enabled
                     else effect.apply_off(model))
        return model

    def bed_model(self) -> PhysicsModel:
        """The physics the bed is poured with: the scene file's effects (``fill.physics:
        scene``) with the run's particle sizes, or the run's own (``run``)."""
        model = self.physics_model()
        if self.fill.physics == 'run' or self.bed_effects is None:
            return model
        base = replace(self, effects=self.bed_effects).physics_model()
        return replace(base, coarse_grain=model.coarse_grain)

    def with_overrides(self, values: Mapping[str, float] | None = None,
                       off: Iterable[str] = (), on: Iterable[str] = (),
                       seed: int | None = None) -> SceneSpec:
        """A copy with effect parameters set (``{'cohesion.energy_density_j_m3': 5e4}``),
        effects switched off or on, and optionally another seed; SceneError on a bad name."""
        raw = {k: {'enabled': v.enabled, **v.values} for k, v in self.effects.items()}
        for dotted, value in (values or {}).items():
            effect, _, param = dotted.partition('.')
            if not param:
                raise SceneError(f'override {dotted!r}: expected EFFECT.PARAMETER=VALUE')
            raw.setdefault(effect, {})[param] = value
            if effect in raw and 'enabled' in raw[effect]:
                raw[effect]['enabled'] = True
        for effect in on:
            raw.setdefault(effect, {})['enabled'] = True
        for effect in off:
            raw.setdefault(effect, {})['enabled'] = False
        effects = read_effects(Reader(raw, 'effects', 'overrides'))
        return replace(self, effects=effects, seed=self.seed if seed is None else seed,
                       bed_effects=self.effects if self.bed_effects is None else self.bed_effects)

    def to_dict(self) -> dict[str, Any]:
        """Plain, JSON-serialisable form (paths as strings), e.g. for cache keys and summaries."""
        out = asdict(self)
        out['tool']['mesh'] = str(self.tool.mesh)
        out['fill']['packing'] = None if self.fill.packing is None else str(self.fill.packing)
        for key in ('effects', 'bed_effects'):
            effects = getattr(self, key) or self.effects
            out[key] = {k: {'enabled': v.enabled, **dict(v.values)} for k, v in effects.items()}
        for key, default in (('sleep', False), ('sleep_scale', 1.0)):
            if out['sim'][key] == default:  # added after libraries and run ids were made: left
                del out['sim'][key]  # out at their defaults, so that those keys stay valid
        return out


def base_model(materials: Mapping[str, MaterialSpec]) -> PhysicsModel:
    p, t, w = materials['particles'], materials['tool'], materials['walls']
    neutral = ContactPair(0.0, 0.0, 0.3)
    return PhysicsModel(
        particle_density_kg_m3=p.density_kg_m3, particle_youngs_modulus_pa=1.7e6,
        particle_poisson=p.poisson_ratio, tool_density_kg_m3=t.density_kg_m3,
        tool_youngs_modulus_pa=float(t.youngs_modulus_pa or 2.1e11),
        tool_poisson=t.poisson_ratio,
        wall_youngs_modulus_pa=float(w.youngs_modulus_pa or 2.1e11),
        wall_poisson=w.poisson_ratio, particle_particle=neutral, particle_tool=neutral,
        particle_wall=neutral)


def _read_effect(effect: Effect, r: Reader) -> EffectSetting:
    enabled = r.flag('enabled', effect.default_enabled)
    if not enabled and not effect.switchable:
        r.fail('enabled', f'effect {effect.name!r} is a model parameter and cannot be '
                          'switched off; change its parameters instead')
    values = {p.name: r.number(p.name, p.low, p.high, p.default) for p in effect.parameters}
    r.finish()
    try:
        effect.apply(_probe_model(), values)
    except ValueError as err:
        r.fail_at(r.path, r.source, str(err))
    return EffectSetting(enabled, values)


def _probe_model() -> PhysicsModel:
    steel = MaterialSpec(7800.0, 0.3, 2.1e11)
    return base_model({'particles': MaterialSpec(1734.0, 0.25), 'tool': steel, 'walls': steel})


def read_effects(r: Reader) -> dict[str, EffectSetting]:
    """Every registered effect's setting from the ``effects`` section (defaults if absent)."""
    effects = all_effects()
    out = {name: _read_effect(effect, r.section(name, required=False))
           for name, effect in effects.items()}
    r.finish()
    return out
