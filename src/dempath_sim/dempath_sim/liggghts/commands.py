"""Building blocks of LIGGGHTS 3.8 input decks shared by the scene backend and validation cases.

Material index ``i`` of :class:`~dempath_sim.engine.params.SimParams` becomes LIGGGHTS atom type
``i + 1``. The contact law is ``pair_style gran model hertz tangential history`` (Hertz normal
force with a dashpot from the restitution, Mindlin tangential spring with history and a Coulomb
limit; Di Renzo & Di Maio 2004, LIGGGHTS doc ``gran_model_hertz``), plus ``rolling_friction
epsd2`` (k_r = k_t R*^2, |M_r| <= mu_r R* |F_n|; Ai et al. 2011) and ``cohesion sjkr``
(F = k_c A_contact) when any pair has a non-zero coefficient, exactly as the dempath engine
switches them. LIGGGHTS has one friction coefficient per pair; see ``friction`` below.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from dempath_sim.engine.params import SimParams
from dempath_sim.liggghts.errors import DeckError
from dempath_sim.scene.spec import SceneSpec

# LIGGGHTS refuses Young's moduli below 5 MPa in SI units unless 'soft_particles yes' is given
# (global_properties.cpp); the paper's sand (Table 6: 1.70 MPa) needs it.
SOFT_LIMIT_PA = 5e6

SPLIT = '* 1 *'  # MPI grid: split X and Z only (bed below, empty tool space above)


def fmt(x: float) -> str:
    """Format a number for a deck: full double precision, no trailing noise."""
    return f'{float(x):.12g}'


def header(box_min: Sequence[float], box_max: Sequence[float], n_types: int, skin_m: float,
           soft: bool, processors: str | None = None) -> list[str]:
    """Atom style, SI units, the fixed box and the neighbour settings.

    Args:
        box_min: (3,) lower corner of the simulation box [m].
        box_max: (3,) upper corner [m].
        n_types: Number of atom (material) types.
        skin_m: Neighbour skin distance [m].
        soft: Allow Young's moduli below 5 MPa (``soft_particles yes``).
        processors: Optional ``processors`` grid, e.g. ``'* 1 *'``.
    """
    lo, hi = [fmt(v) for v in box_min], [fmt(v) for v in box_max]
    lines = ['atom_style granular', 'atom_modify map array', 'boundary f f f', 'newton off',
             'communicate single vel yes', 'units si']
    if soft:
        lines.append('soft_particles yes')
    if processors:
        lines.append(f'processors {processors}')
    lines += [f'region domain block {lo[0]} {hi[0]} {lo[1]} {hi[1]} {lo[2]} {hi[2]} units box',
              f'create_box {n_types} domain', f'neighbor {fmt(skin_m)} bin',
              'neigh_modify delay 0']
    return lines


def _pair_matrix(params: SimParams, name: str, value: str) -> str:
    n = len(params.materials)
    vals = []
    for i in range(n):
        for j in range(n):
            inter = params.interaction(i, j) if params.has_interaction(i, j) else None
            vals.append(fmt(getattr(inter, value)) if inter is not None else '0')
    return f'fix m_{name} all property/global {name} peratomtypepair {n} ' + ' '.join(vals)


def _restitution_matrix(params: SimParams) -> str:
    n = len(params.materials)
    vals = []
    for i in range(n):
        for j in range(n):
            ok = params.has_interaction(i, j)
            vals.append(fmt(params.interaction(i, j).restitution) if ok else '0.5')
    return f'fix m_coefficientRestitution all property/global coefficientRestitution ' \
           f'peratomtypepair {n} ' + ' '.join(vals)


def materials(params: SimParams, friction: str = 'static') -> list[str]:
    """``fix property/global`` lines for every material and pair.

    Args:
        params: dempath parameters (materials and pair interactions).
        friction: Which dempath coefficient becomes LIGGGHTS' single Coulomb coefficient:
            ``'static'`` (the stick limit, default) or ``'dynamic'``.

    Raises:
        DeckError: ``friction`` is not 'static' or 'dynamic'.
    """
    if friction not in ('static', 'dynamic'):
        msg = f'friction: must be static or dynamic, got {friction!r}'
        raise DeckError(msg)
    mats = params.materials
    lines = [
        'fix m_youngsModulus all property/global youngsModulus peratomtype '
        + ' '.join(fmt(m.youngs_modulus) for m in mats),
        'fix m_poissonsRatio all property/global poissonsRatio peratomtype '
        + ' '.join(fmt(m.poisson_ratio) for m in mats),
        _restitution_matrix(params),
        _pair_matrix(params, 'coefficientFriction', f'{friction}_friction'),
    ]
    if params.rolling_enabled:
        lines.append(_pair_matrix(params, 'coefficientRollingFriction', 'rolling_resistance'))
    if params.cohesion_enabled:
        lines.append(_pair_matrix(params, 'cohesionEnergyDensity', 'cohesion_energy_density'))
    return lines


def contact_model(params: SimParams) -> str:
    """The granular model words shared by ``pair_style gran`` and ``fix wall/gran``.

    LIGGGHTS 3.8 reads them in a fixed order (model, tangential, cohesion, rolling_friction,
    surface) and rejects any other ("wrong keyword order"), so cohesion comes first.
    """
    words = 'model hertz tangential history'
    if params.cohesion_enabled:
        words += ' cohesion sjkr'
    if params.rolling_enabled:
        words += ' rolling_friction epsd2'
    return words


def pair_style(params: SimParams) -> list[str]:
    """``pair_style gran ...`` and ``pair_coeff * *``."""
    return [f'pair_style gran {contact_model(params)}', 'pair_coeff * *']


def gravity(params: SimParams) -> list[str]:
    """``fix gravity`` along the dempath gravity vector (-Y by default)."""
    g = params.gravity
    mag = math.sqrt(sum(c * c for c in g))
    if mag == 0.0:
        return []
    unit = ' '.join(fmt(c / mag) for c in g)
    return [f'fix gravi all gravity {fmt(mag)} vector {unit}']


def plane_wall(name: str, params: SimParams, axis: str, offset_m: float,
               material: int) -> str:
    """A primitive plane wall ``fix wall/gran ... primitive type T {x,y,z}plane offset``."""
    if axis not in ('x', 'y', 'z'):
        msg = f'plane_wall axis: must be x, y or z, got {axis!r}'
        raise DeckError(msg)
    return (f'fix {name} all wall/gran {contact_model(params)} primitive type {material + 1} '
            f'{axis}plane {fmt(offset_m)}')


def mesh_wall(name: str, params: SimParams, mesh_ids: Sequence[str]) -> str:
    """``fix wall/gran`` over one or more ``fix mesh/surface`` meshes."""
    return (f'fix {name} all wall/gran {contact_model(params)} mesh n_meshes {len(mesh_ids)} '
            f'meshes {" ".join(mesh_ids)}')


def needs_soft(params: SimParams) -> bool:
    """Whether any material is softer than LIGGGHTS' 5 MPa SI limit."""
    return any(m.youngs_modulus < SOFT_LIMIT_PA for m in params.materials)


def write_ascii_stl(path: str, triangles: Sequence[Sequence[Sequence[float]]],
                    name: str = 'mesh') -> None:
    """Write triangles (n, 3, 3) [m] as an ASCII STL (LIGGGHTS reads ASCII STL only)."""
    out = [f'solid {name}']
    for tri in triangles:
        (ax, ay, az), (bx, by, bz), (cx, cy, cz) = tri
        ux, uy, uz = bx - ax, by - ay, bz - az
        vx, vy, vz = cx - ax, cy - ay, cz - az
        nx, ny, nz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
        norm = math.sqrt(nx * nx + ny * ny + nz * nz) or 1.0
        out.append(f' facet normal {fmt(nx / norm)} {fmt(ny / norm)} {fmt(nz / norm)}')
        out.append('  outer loop')
        out += [f'   vertex {fmt(p[0])} {fmt(p[1])} {fmt(p[2])}' for p in tri]
        out += ['  endloop', ' endfacet']
    out.append(f'endsolid {name}')
    with open(path, 'w') as fh:
        fh.write('\n'.join(out) + '\n')


def physics(params: SimParams, dt: float, friction: str) -> list[str]:
    """Materials, contact law, gravity, time step and the integrator."""
    return [*materials(params, friction), *pair_style(params), *gravity(params),
            f'timestep {fmt(dt)}', 'fix integr all nve/sphere']


def bin_walls(scene: SceneSpec, params: SimParams, wall_type: int) -> list[str]:
    """Floor and four side walls of the bin as primitive planes (open top)."""
    w, floor = scene.bin.width_x_m / 2, -scene.bed_thickness_m
    planes = (('y', floor), ('x', -w), ('x', w), ('z', 0.0), ('z', scene.bin.length_z_m))
    return [plane_wall(f'wall{k}', params, axis, off, wall_type)
            for k, (axis, off) in enumerate(planes)]
