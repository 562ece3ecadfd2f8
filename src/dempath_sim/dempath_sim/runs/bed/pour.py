# mypy: disable-error-code="no-untyped-def"
"""The loose pour: each layer's spheres at random, non-overlapping places in a slab of the bin.

This is what LIGGGHTS' ``fix insert/pack`` with ``volumefraction_region`` does: random sequential
insertion (each sphere tried at uniformly random centres until it overlaps none placed before)
into a region sized so that the layer's spheres fill it at ``fill.pour_solid_fraction`` (0.35 by
default; random sequential insertion of equal spheres jams near 0.38, Torquato et al., Phys. Rev.
E 74, 061308, 2006). A sphere that finds no room in ``MAX_ATTEMPTS`` tries raises the slab's top
by a quarter diameter, so the insertion always ends (slightly looser than asked near jamming).
The layers are stacked (the first on the floor) and fall together when the settle starts.
Spheres are inserted largest first, at rest.

``lattice_pour`` keeps dempath's earlier jittered-lattice pour for benchmarks that need a closed
bed of millions of spheres without settling it (``bench/paper_scene_steps.py``).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numba import njit
from numpy.typing import NDArray

from dempath_sim.effects import PhysicsModel
from dempath_sim.engine.params import SimParams
from dempath_sim.engine.state import SimState
from dempath_sim.runs.physics import PARTICLES
from dempath_sim.scene.spec import LayerSpec, SceneSpec

F64 = NDArray[np.float64]
DEFAULT_SOLID_FRACTION = 0.6  # random loose-to-close packing of spheres
LATTICE_GAP = 1.04  # lattice spacing / largest diameter of a layer (lattice_pour)
MAX_ATTEMPTS = 5000  # random tries per sphere before its slab grows (by a quarter diameter)


def target_solid_fraction(scene: SceneSpec, model: PhysicsModel) -> float:
    """Solid fraction the layers' particle count is made for: target density / particle
    density (clipped to [0.05, 0.64]), or 0.6 without a target."""
    target = scene.fill.bulk_density_target_kg_m3
    if target is None:
        return DEFAULT_SOLID_FRACTION
    return float(min(max(target / model.particle_density_kg_m3, 0.05), 0.64))


def sample_diameters(layer: LayerSpec, factor: float, volume_m3: float,
                     rng: np.random.Generator) -> F64:
    """Diameters [m] of one layer whose sphere volumes add up to ``volume_m3``."""
    d0 = layer.diameter_m * factor
    dist = layer.distribution
    n_guess = max(1, math.ceil(volume_m3 / (math.pi / 6 * d0**3) * 1.3))
    if dist.kind == 'uniform':
        d = d0 * (1.0 + dist.spread * rng.uniform(-1.0, 1.0, n_guess))
    elif dist.kind == 'discrete':
        sizes = np.asarray(dist.diameters_m) * factor
        number_w = np.asarray(dist.mass_fractions) / sizes**3  # mass fraction -> number fraction
        d = rng.choice(sizes, size=n_guess * 4, p=number_w / number_w.sum())
    else:
        d = np.full(n_guess, d0)
    cum = np.cumsum(math.pi / 6 * d**3)
    return d[: int(np.searchsorted(cum, volume_m3)) + 1]


@njit(cache=True)
def insert_random(radii, lo, hi, y_cap, seed, max_attempts):  # pragma: no cover - compiled
    """Random sequential insertion of spheres ``radii`` (n,), largest first.

    Centres lie in the box lo..hi (3,) shrunk by each radius; a sphere that finds no room in
    ``max_attempts`` tries raises hi[1] by a quarter of the largest diameter (at most to
    ``y_cap``).

    Returns:
        (centres (n, 3) [m], the slab's final top [m]).
    """
    np.random.seed(seed)
    n = radii.shape[0]
    big = 2.0 * radii.max()
    dims = np.empty(3, np.int64)
    for a in range(3):
        top = y_cap if a == 1 else hi[a]
        dims[a] = max(1, int((top - lo[a]) / big) + 1)
    head = np.full(dims[0] * dims[1] * dims[2], -1, np.int64)
    nxt = np.full(n, -1, np.int64)
    out = np.zeros((n, 3))
    top_y = hi[1]
    for i in np.argsort(-radii):
        r = radii[i]
        tries = 0
        while True:
            p = np.empty(3)
            for a in range(3):
                upper = top_y if a == 1 else hi[a]
                p[a] = lo[a] + r + np.random.random() * max(upper - lo[a] - 2.0 * r, 0.0)
            c = np.empty(3, np.int64)
            for a in range(3):
                c[a] = min(max(int((p[a] - lo[a]) / big), 0), dims[a] - 1)
            free = True
            for dx in range(-1, 2):
                for dy in range(-1, 2):
                    for dz in range(-1, 2):
                        cx, cy, cz = c[0] + dx, c[1] + dy, c[2] + dz
                        if (cx < 0 or cy < 0 or cz < 0 or cx >= dims[0] or cy >= dims[1]
                                or cz >= dims[2]):
                            continue
                        j = head[(cx * dims[1] + cy) * dims[2] + cz]
                        while j >= 0 and free:
                            d2 = ((out[j, 0] - p[0]) ** 2 + (out[j, 1] - p[1]) ** 2
                                  + (out[j, 2] - p[2]) ** 2)
                            if d2 < (r + radii[j]) ** 2:
                                free = False
                            j = nxt[j]
            if free:
                break
            tries += 1
            if tries >= max_attempts:
                tries = 0
                top_y = min(top_y + 0.25 * big, y_cap)
        out[i] = p
        cell = (c[0] * dims[1] + c[1]) * dims[2] + c[2]
        nxt[i] = head[cell]
        head[cell] = i
    return out, top_y


def layer_slab(scene: SceneSpec, diameters: F64, y_start: float, rng: np.random.Generator,
               fraction: float) -> tuple[F64, float]:
    """Random centres (n, 3) [m] of one layer in a slab from ``y_start`` holding its spheres at
    solid fraction ``fraction``; the slab's top [m]."""
    half_w, length = scene.bin.width_x_m / 2, scene.bin.length_z_m
    volume = float(np.sum(math.pi / 6 * diameters**3))
    height = max(volume / (fraction * 2 * half_w * length), float(diameters.max()))
    lo = np.array([-half_w, y_start, 0.0])
    hi = np.array([half_w, y_start + height, length])
    cap = y_start + 4.0 * height + 10.0 * float(diameters.max())
    seed = int(rng.integers(0, 2**31 - 1))
    centres, top = insert_random(diameters / 2, lo, hi, cap, seed, MAX_ATTEMPTS)
    return np.asarray(centres), float(top)


def _state(layers: list[tuple[F64, F64]], params: SimParams) -> SimState:
    positions = np.concatenate([p for p, _ in layers])
    radii = np.concatenate([d / 2 for _, d in layers])
    state = SimState.from_spheres(positions, radii, PARTICLES, params)
    state.extra['layer'] = np.concatenate(
        [np.full(len(d), k, np.int32) for k, (_, d) in enumerate(layers)])
    return state


Placer = Callable[[F64, float, np.random.Generator], tuple[F64, float]]


def _stack(scene: SceneSpec, model: PhysicsModel, params: SimParams, place: Placer,
           count_scale: float = 1.0) -> SimState:
    """Every layer's spheres (target solid fraction x layer volume x ``count_scale``), placed by
    ``place`` (diameters, bottom y, rng -> centres, top y) one on top of the other from the
    floor."""
    rng = np.random.default_rng(scene.seed)
    phi = target_solid_fraction(scene, model) * count_scale
    area = scene.bin.width_x_m * scene.bin.length_z_m
    y, layers = -scene.bed_thickness_m, []
    for layer in scene.layers:
        factor = model.coarse_grain if layer.coarse_grained else 1.0
        d = sample_diameters(layer, factor, phi * area * layer.thickness_m, rng)
        pos, y = place(d, y, rng)
        layers.append((pos, d))
    return _state(layers, params)


def pour(scene: SceneSpec, model: PhysicsModel, params: SimParams,
         count_scale: float = 1.0) -> SimState:
    """The loose random pour of all layers, seeded by ``scene.seed``; ``extra['layer']``.

    Each layer holds target solid fraction x layer volume x ``count_scale`` of spheres
    (``fill.count: surface`` scales the number to bring the settled surface to Y = 0), inserted
    at random into its own slab (``fill.pour_solid_fraction``) on top of the one below.
    """
    fraction = scene.fill.pour_solid_fraction
    return _stack(scene, model, params,
                  lambda d, y, rng: layer_slab(scene, d, y, rng, fraction), count_scale)


def lattice(scene: SceneSpec, diameters: F64, y_start: float, rng: np.random.Generator,
            gap: float = LATTICE_GAP) -> tuple[F64, float]:
    """Jittered cubic-lattice centres (n, 3) [m] for ``diameters`` above ``y_start``; top y.

    ``gap`` is the lattice spacing over the largest diameter (< 1 puts neighbours in contact).
    """
    a = float(diameters.max()) * gap
    half_w = scene.bin.width_x_m / 2
    nx = max(1, int((scene.bin.width_x_m - a) // a) + 1)
    nz = max(1, int((scene.bin.length_z_m - a) // a) + 1)
    k = np.arange(len(diameters))
    ix, iz, iy = k % nx, (k // nx) % nz, k // (nx * nz)
    jitter = rng.uniform(-1.0, 1.0, (len(k), 3)) * 0.5 * (a - diameters[:, None]) / 2
    pos = np.column_stack([-half_w + a / 2 + ix * a, y_start + a / 2 + iy * a, a / 2 + iz * a])
    return pos + jitter, y_start + (int(iy.max()) + 1) * a


def lattice_pour(scene: SceneSpec, model: PhysicsModel, params: SimParams,
                 gap: float = LATTICE_GAP) -> SimState:
    """All layers on jittered cubic lattices (dempath's pour before issue 12), at rest."""
    return _stack(scene, model, params, lambda d, y, rng: lattice(scene, d, y, rng, gap))


__all__ = ['DEFAULT_SOLID_FRACTION', 'LATTICE_GAP', 'insert_random', 'lattice', 'lattice_pour',
           'layer_slab', 'pour', 'sample_diameters', 'target_solid_fraction']
