"""The packing cache: the key of a settled bed, and the beds kept on disk and shipped.

Settled packings are cached as ``<cache>/<key>.npz``; the key hashes everything that determines
the packing (bin, layers, particle and wall physics, fill settings, numerics, seed, engine
version), so repeated runs of a scene, and runs that only change the tool or its speed, skip
the fill. A bed poured around the standing tool (``tool.placement: poured``) belongs to the
tool: its key includes it (``standing_tool.tool_key``). dempath ships packings of its bundled
scenes (``bundled_packing_dir``), looked up after the user's cache.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import zipfile
from dataclasses import asdict, replace
from pathlib import Path
from typing import Any

import numpy as np

from dempath_sim.effects import PhysicsModel
from dempath_sim.engine.params import SimParams
from dempath_sim.engine.state import SimState
from dempath_sim.runs.bed.measure import FillReport
from dempath_sim.runs.bed.standing_tool import tool_key
from dempath_sim.runs.physics import PARTICLES
from dempath_sim.scene.spec import FillSpec, NumericsSpec, SceneSpec

logger = logging.getLogger(__name__)


FILL_VERSION = 2  # bump when the pour/settle procedure changes (invalidates cached packings)
# Bump when an engine change alters the physics of settling (invalidates packings). Changes that
# only reorder floating-point sums (cell-order sorting of particles, per-patch mesh history: the
# fill has no tool) leave a cached bed an equally valid sample of the same physics, so they keep
# the version and the shipped packing.
ENGINE_VERSION = 1


def default_cache_dir() -> Path:
    """``$DEMPATH_CACHE_DIR/packings`` or ``~/.cache/dempath/packings``."""
    root = os.environ.get('DEMPATH_CACHE_DIR')
    base = Path(root) if root else Path.home() / '.cache' / 'dempath'
    return base / 'packings'


# The overlap-limit value every packing key is made with: the default when the shipped packings
# were made; a later default does not change the keys.
KEY_OVERLAP_FRACTION = 0.3


def bundled_packing_dir() -> Path:
    """Settled packings shipped with dempath for its bundled scenes (read-only, looked up last)."""
    return Path(__file__).resolve().parents[2] / 'data' / 'packings'


def packing_key(scene: SceneSpec, model: PhysicsModel) -> str:
    """Hash (hex, 20 chars) of everything that determines the settled packing.

    The overlap limit is a safety stop, not a parameter of the packing, so it is left out (set
    to KEY_OVERLAP_FRACTION, whatever the scene says) along with everything about the tool.
    """
    numerics = asdict(replace(scene.sim, max_overlap_fraction=KEY_OVERLAP_FRACTION))
    del numerics['sleep'], numerics['sleep_scale']  # the pass's options: fills never sleep
    for option in ('coulomb_limit', 'contact_forms'):  # options added after packings were
        if numerics[option] == getattr(NumericsSpec, option):  # shipped: at their defaults
            del numerics[option]  # the keys of those packings stay valid
    fill = asdict(replace(scene.fill, cache=True))
    if fill['count'] == FillSpec.count:  # added after packings were shipped, likewise
        del fill['count']
    if numerics.get('contact_forms') == 'liggghts':  # its pair springs now outlive a
        numerics['pair_springs'] = 'until_list_build'  # separation: packings settled before
    physics = asdict(replace(model, speed_scale=1.0, particle_tool=model.particle_particle,
                             tool_density_kg_m3=0.0, tool_youngs_modulus_pa=0.0,
                             tool_poisson=0.0))
    payload = {'version': FILL_VERSION, 'engine': ENGINE_VERSION,
               'bin': asdict(scene.bin), 'layers': [asdict(x) for x in scene.layers],
               'physics': physics, 'fill': fill,
               'sim': numerics,
               'seed': scene.seed}
    standing = tool_key(scene)
    if standing is not None:  # a bed poured around the tool belongs to the tool
        payload['tool'] = standing
    text = json.dumps(payload, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:20]


def save_cached(path: Path, state: SimState, report: FillReport) -> None:
    """Write the packing beside its final name and rename it into place (atomic: a killed run
    leaves no half-written entry; concurrent writers each use their own temporary file)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f'.{path.stem}.{os.getpid()}.tmp.npz')
    np.savez_compressed(tmp, positions=state.positions, velocities=state.velocities,
                        angular_velocities=state.angular_velocities, radii=state.radii,
                        ids=state.ids, layer=state.extra.get('layer', np.zeros(state.n)),
                        report=np.array(json.dumps(asdict(report))))
    tmp.replace(path)


# What a damaged cache entry raises on reading: truncated or empty zip (BadZipFile, EOFError),
# a missing array (KeyError), wrong shapes or JSON (ValueError, TypeError), unreadable (OSError).
_DAMAGED = (zipfile.BadZipFile, EOFError, KeyError, ValueError, TypeError, OSError)


def load_cached(path: Path, params: SimParams) -> tuple[SimState, FillReport] | None:
    """The cached packing, or None when the entry is damaged: it is then named in a warning,
    set aside as ``<name>.corrupt`` (when the cache is writable) and the bed is poured again."""
    try:
        with np.load(path, allow_pickle=False) as data:
            state = SimState.from_spheres(data['positions'], data['radii'], PARTICLES, params,
                                          velocities=data['velocities'], ids=data['ids'])
            state.angular_velocities[:] = data['angular_velocities']
            state.extra['layer'] = data['layer'].astype(np.int32)
            fields: dict[str, Any] = json.loads(str(data['report']))
        fields['from_cache'] = True
        report = FillReport(**fields)
    except _DAMAGED as err:
        aside = path.with_name(path.name + '.corrupt')
        try:
            path.replace(aside)
            where = f'set aside as {aside.name}'
        except OSError:
            where = 'left in place (read-only)'
        logger.warning('fill: cached packing %s is damaged (%s: %s); %s, pouring the bed again',
                       path, type(err).__name__, err, where)
        return None
    logger.info('fill: packing %s read from the cache', path.name)
    return state, report
