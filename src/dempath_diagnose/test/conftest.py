"""Shared fixtures of the dempath_diagnose tests: a small signature library on the tiny scene.

The library (3 seeds; cohesion, tool speed and tool friction at one strength each) and the
packings are built once per test session in a temporary folder: about a dozen tiny runs. Under
pytest-xdist the workers build it once between them (the first takes a lock on a folder of the
run that every worker sees, the others wait for it) and each copies it into its own cache, so the
tests of one worker never see what another's tests add to theirs.
"""

from __future__ import annotations

import fcntl
import os
import shutil
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
def tiny_library(cache: Path, tmp_path_factory: pytest.TempPathFactory) -> Library:
    """The tiny scene's test library (built once per session, shared by the xdist workers)."""
    scene = load_scene(SCENE)
    if 'PYTEST_XDIST_WORKER' not in os.environ:
        return Library.load(build_library(scene, SPEC, cache / 'library',
                                          cache_dir=cache / 'packings'))
    shared = tmp_path_factory.getbasetemp().parent / 'diagnose-shared'  # every worker's, this run
    shared.mkdir(exist_ok=True)
    with (shared / 'build.lock').open('w') as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes
        # build_library rewrites the folder's design.json even when every run is stored, so the
        # copy is made under the lock too (else another worker's call can truncate it meanwhile)
        folder = build_library(scene, SPEC, shared / 'library', cache_dir=shared / 'packings')
        shutil.copytree(shared / 'packings', cache / 'packings', dirs_exist_ok=True)
        own = cache / 'library' / folder.name
        shutil.copytree(folder, own, dirs_exist_ok=True)
    return Library.load(own)


@pytest.fixture(scope='session')
def geometry() -> CaseGeometry:
    """Tool axis, axis half width and cube of the tiny scene."""
    x, half, cube = tool_geometry(load_scene(SCENE))
    return CaseGeometry(x, half, cube)
