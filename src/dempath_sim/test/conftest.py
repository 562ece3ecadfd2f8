"""Fixtures shared by the dempath_sim tests."""

from __future__ import annotations

import pytest

from dempath.nodes.pytest_plugin import require_component
from dempath_sim.liggghts.errors import LiggghtsNotFoundError
from dempath_sim.liggghts.install import LiggghtsInstall, ensure_liggghts


@pytest.fixture(scope='session')
def liggghts() -> LiggghtsInstall:
    """LIGGGHTS 3.8 (Debian package), installed by apt-get when root; else the test fails."""
    try:
        return ensure_liggghts(install=True)
    except LiggghtsNotFoundError as err:
        require_component('liggghts', err)
