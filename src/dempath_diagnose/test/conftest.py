"""Shared fixtures of the dempath_diagnose tests: a small signature library on the tiny scene.

The library (3 seeds; cohesion, tool speed and tool friction at one strength each) and the
packings are built once per test session in a temporary folder: about a dozen tiny runs.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from dempath_diagnose.decision.diagnosis import CaseGeometry
from dempath_diagnose.library.simulator import load_scene, tool_geometry
from dempath_diagnose.library.store import Library, LibrarySpec, build_library

SCENE = 'builtin:tiny'
SPEC = LibrarySpec(seeds=(1001, 1002, 1003), candidates=('cohesion', 'tool_speed',
                                                          'tool_friction'),
                   duration_s=0.54, n_strengths=1)


@pytest.fixture(scope='session')
def cache(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Packing cache and library root of the session."""
    return tmp_path_factory.mktemp('diagnose-cache')


@pytest.fixture(scope='session')
def tiny_library(cache: Path) -> Library:
    """The tiny scene's test library (built once per session)."""
    scene = load_scene(SCENE)
    folder = build_library(scene, SPEC, cache / 'library', cache_dir=cache / 'packings')
    return Library.load(folder)


@pytest.fixture(scope='session')
def geometry() -> CaseGeometry:
    """Tool axis, axis half width and cube of the tiny scene."""
    x, half, cube = tool_geometry(load_scene(SCENE))
    return CaseGeometry(x, half, cube)
