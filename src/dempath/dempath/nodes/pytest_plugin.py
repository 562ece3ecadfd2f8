"""pytest fixtures for launch-free node tests (loaded by ``-p dempath.nodes.pytest_plugin``).

``ros_harness`` gives each test a private context and ROS domain with a probe node; start nodes
under test with ``ros_harness.start(NodeClass, param=value)`` and wait with ``spin_until``.

``require_component`` is what a fixture calls when a component the suite expects (LIGGGHTS,
Chromium) is missing and cannot be installed: the test fails, so a green run never hides
the checks it skipped, unless the component is listed on purpose in ``DEMPATH_TEST_SKIP``
(comma-separated, e.g. ``DEMPATH_TEST_SKIP=liggghts,chromium``); such skips are counted and
listed at the end of the run.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from typing import NoReturn

import numpy as np
import pytest

from dempath.nodes.harness import RosHarness
from dempath.rosenv import apply_ros_defaults

apply_ros_defaults()

SKIP_VARIABLE = 'DEMPATH_TEST_SKIP'  # components whose tests may be skipped, comma-separated
_DELIBERATE: set[str] = set()


def deliberate_skips() -> set[str]:
    """Components listed in ``DEMPATH_TEST_SKIP``."""
    return {c.strip().lower() for c in os.environ.get(SKIP_VARIABLE, '').split(',') if c.strip()}


def require_component(name: str, problem: object) -> NoReturn:
    """Fail the test for a missing component, or skip it when ``name`` is listed on purpose.

    Args:
        name: The component (``liggghts``, ``chromium``).
        problem: Why it is missing (the finder's error, naming the command to install it).
    """
    if name.lower() in deliberate_skips():
        _DELIBERATE.add(name.lower())
        pytest.skip(f'{name}: skipped on purpose ({SKIP_VARIABLE}): {problem}')
    pytest.fail(f'{name} is expected and missing: {problem} (install it, or list it in '
                f'{SKIP_VARIABLE} to skip its tests on purpose)', pytrace=False)


def pytest_terminal_summary(terminalreporter: pytest.TerminalReporter) -> None:
    """List the components whose tests were skipped on purpose."""
    listed = deliberate_skips()
    if listed:
        terminalreporter.write_line(
            f'{SKIP_VARIABLE}={",".join(sorted(listed))}: tests of these components are '
            'skipped on purpose when they are missing')


@pytest.fixture
def ros_harness() -> Iterator[RosHarness]:
    """A single-threaded RosHarness, shut down after the test whatever happens."""
    harness = RosHarness()
    try:
        yield harness
    finally:
        harness.shutdown()


@pytest.fixture
def ros_harness_mt() -> Iterator[RosHarness]:
    """A two-thread RosHarness for nodes that do work in callbacks while others publish."""
    harness = RosHarness(threads=2)
    try:
        yield harness
    finally:
        harness.shutdown()


@pytest.fixture
def strict_numpy() -> Iterator[None]:
    """Turn numpy floating-point warnings into errors for the duration of a test."""
    old = np.seterr(all='raise')
    try:
        yield
    finally:
        np.seterr(**old)
