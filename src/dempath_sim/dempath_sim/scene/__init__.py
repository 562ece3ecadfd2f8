"""Scenes: reading and validating scene files into frozen records.

`loader.py` reads a YAML scene (or a shipped one) strictly through `_reader.py`; `spec.py` holds
the records (`SceneSpec` and its parts) and the effect settings; `profiles.py` the tool's speed
profile and path. Errors are `dempath_sim.errors.SceneError`, one line naming file and key.
"""

from __future__ import annotations

from dempath_sim.errors import SceneError
from dempath_sim.scene.loader import (
    SCENES_DIR,
    bundled_scene,
    list_bundled_scenes,
    load_scene,
    parse_overrides,
    resolve_scene,
    scene_from_dict,
)
from dempath_sim.scene.profiles import SpeedProfile, ToolPath
from dempath_sim.scene.spec import (
    BinSpec,
    EffectSetting,
    FillSpec,
    LayerSpec,
    MarkerSpec,
    MaterialSpec,
    NumericsSpec,
    OutputSpec,
    SceneSpec,
    SizeDistribution,
    ToolSpec,
)

__all__ = ['SCENES_DIR', 'BinSpec', 'EffectSetting', 'FillSpec', 'LayerSpec', 'MarkerSpec',
           'MaterialSpec', 'NumericsSpec', 'OutputSpec', 'SceneError', 'SceneSpec',
           'SizeDistribution', 'SpeedProfile', 'ToolPath', 'ToolSpec', 'bundled_scene',
           'list_bundled_scenes', 'load_scene', 'parse_overrides', 'resolve_scene',
           'scene_from_dict']
