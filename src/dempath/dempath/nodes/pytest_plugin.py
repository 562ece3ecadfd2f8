"""pytest fixtures for launch-free node tests (loaded by ``-p dempath.nodes.pytest_plugin``).

``ros_harness`` gives each test a private context and ROS domain with a probe node; start nodes
under test with ``ros_harness.start(NodeClass, param=value)`` and wait with ``spin_until``.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import pytest

from dempath.nodes.harness import RosHarness
from dempath.rosenv import apply_ros_defaults

apply_ros_defaults()


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
