"""A signature library against its scene: what it stores of the scene, and the check on load.

A library (folder or packed file) is for one scene: it carries the scene's name, its physics
key (:func:`~dempath_diagnose.library.simulator.physics_key`) and one key per part of the scene
(bin, layers, materials, effects, tool, markers, fill, numerics). Another scene or other
physics is refused in one line naming the parts that differ: a wrong pairing would give a
confident wrong answer, not an error.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any

from dempath_diagnose.errors import LibraryError
from dempath_diagnose.library.simulator import SceneSpec, physics_key, scene_parts

PARTS = ('bin', 'layers', 'materials', 'effects', 'bed_effects', 'tool', 'markers', 'fill',
         'sim')


def scene_identity(scene: SceneSpec) -> dict[str, Any]:
    """What a library stores about its scene: name, physics key and one key per part."""
    parts = scene_parts(scene)
    return {'scene': scene.name, 'physics_key': physics_key(scene),
            'parts': {k: _digest(parts[k]) for k in PARTS if k in parts}}


def _digest(value: Any) -> str:
    text = json.dumps(value, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def check_library_scene(library_path: Path, stored: dict[str, Any], scene: SceneSpec) -> None:
    """Refuse a library built for another scene or other physics.

    Args:
        library_path: The library (for messages).
        stored: Its identity (:func:`scene_identity` as stored; may be partial for an older
            library: then only the scene name is compared).
        scene: The scene of this diagnosis.

    Raises:
        LibraryError: One line naming the library, both scenes and the parts that differ.
    """
    mine = scene_identity(scene)
    name = stored.get('scene')
    key = stored.get('physics_key')
    if key is None:
        if name is not None and name != scene.name:
            msg = (f'{library_path}: the library is for scene {name!r}, not {scene.name!r} '
                   '(it carries no physics key: an older library)')
            raise LibraryError(msg)
        return
    if key == mine['physics_key']:
        return
    theirs = stored.get('parts') or {}
    differ = [p for p in PARTS if theirs.get(p) != mine['parts'].get(p)] if theirs else []
    what = ', '.join(differ) if differ else 'its physics'
    msg = (f'{library_path}: the library is for scene {name!r} (physics key {key}), not for '
           f'{scene.name!r} (physics key {mine["physics_key"]}): they differ in {what}')
    raise LibraryError(msg)
