"""The launch files' graphs against what the packages really provide.

``launch`` and ``launch_ros`` are not on the package index, so the launch description cannot be
loaded here (docs/ros.md). What a ``ros2 launch`` would trip over is checked instead: each
launch file builds its graph from :mod:`dempath_bringup.launchgraph`; every executable is a
console script of the package named; the parameter file has a block for each node and none
other; and each node, built in-process with that block (plus the launch arguments' parameters),
declares every parameter given to it with the type given (rclpy rejects a wrong type).
"""

from __future__ import annotations

import ast
from importlib.metadata import distribution
from pathlib import Path
from typing import Any

import pytest
import yaml
from rclpy.parameter import Parameter

from dempath.frames import save_frames, scene_transforms
from dempath.nodes.harness import RosHarness
from dempath_bringup.launchgraph import ARGUMENTS, GRAPHS, NodeSpec
from dempath_twin.rig import paper_rig

ROOT = Path(__file__).resolve().parents[1]
BRINGUP = ROOT / 'src' / 'dempath_bringup'


def console_script(spec: NodeSpec) -> str:
    """``module:function`` of the executable in its package's console scripts ('' if none)."""
    eps = distribution(spec.package).entry_points
    found = [ep.value for ep in eps
             if ep.group == 'console_scripts' and ep.name == spec.executable]
    return found[0] if found else ''


def node_class(spec: NodeSpec) -> Any:
    """The rclpy Node subclass the executable's module defines."""
    import importlib

    from rclpy.node import Node

    module = importlib.import_module(console_script(spec).split(':')[0])
    (cls,) = [v for v in vars(module).values() if isinstance(v, type) and issubclass(v, Node)
              and v is not Node and v.__module__ == module.__name__]
    return cls


@pytest.mark.parametrize('graph', sorted(GRAPHS))
def test_launch_file_and_parameter_file_exist_and_name_the_graph(graph: str) -> None:
    """launch/<graph>.launch.py returns graph_launch_description(<graph>), which builds
    GRAPHS[<graph>] with config/<graph>.yaml; setup.py installs both into share/."""
    source = (BRINGUP / 'launch' / f'{graph}.launch.py').read_text()
    tree = ast.parse(source)
    consts = {t.id: n.value.value for n in tree.body if isinstance(n, ast.Assign)
              for t in n.targets if isinstance(t, ast.Name) and isinstance(n.value, ast.Constant)}
    assert consts.get('GRAPH') == graph
    (func,) = [n for n in tree.body if isinstance(n, ast.FunctionDef)
               and n.name == 'generate_launch_description']
    calls = [n for n in ast.walk(func) if isinstance(n, ast.Call)]
    assert [ast.unparse(c) for c in calls] == ['graph_launch_description(GRAPH)']
    assert (BRINGUP / 'config' / f'{graph}.yaml').is_file()
    setup = (BRINGUP / 'setup.py').read_text()
    assert "f'share/{PACKAGE}/launch'" in setup and "f'share/{PACKAGE}/config'" in setup


@pytest.mark.parametrize('graph', sorted(GRAPHS))
def test_every_executable_is_a_console_script(graph: str) -> None:
    """``ros2 run`` and launch find ``lib/<package>/<executable>``: the package's script."""
    for spec in GRAPHS[graph]:
        target = console_script(spec)
        assert target.endswith(':main') and '.nodes.' in target, (spec, target)


@pytest.mark.parametrize('graph', sorted(GRAPHS))
def test_nodes_declare_every_parameter_given(graph: str, tmp_path: Path) -> None:
    """Each block of config/<graph>.yaml (and each launch argument's parameter) is declared by
    its node, with a value of the declared type."""
    blocks = yaml.safe_load((BRINGUP / 'config' / f'{graph}.yaml').read_text())
    specs = {spec.yaml_key: spec for spec in GRAPHS[graph]}
    assert set(blocks) == set(specs), f'{graph}.yaml blocks vs graph nodes'
    arguments = {a.name for a in ARGUMENTS[graph]}
    # the detectors read the scene's marker grid (a real scene); the simulator would run it, so
    # it gets a missing file and aborts its run in its thread (the parameters are declared)
    scene = 'tiny' if graph == 'live' else str(tmp_path / 'no_scene.yaml')
    files = {'calibration': str(paper_rig().save(tmp_path / 'stereo.yaml')),
             'bag': str(tmp_path / 'no_bag'), 'scene': scene,
             'output': str(tmp_path / 'out_bag'), 'rate': 0.25,
             'frames': str(save_frames(tmp_path / 'frames.yaml', scene_transforms()))}
    with RosHarness() as harness:
        for key, spec in specs.items():
            given = dict(blocks[key]['ros__parameters'])
            for param, arg in spec.arguments:
                assert arg in arguments, f'{spec.executable}: no launch argument {arg}'
                given[param] = files[arg]
            overrides = [Parameter(k, value=v) for k, v in given.items()]
            node = harness.add(node_class(spec)(context=harness.context,
                                                namespace=spec.namespace or None,
                                                parameter_overrides=overrides))
            undeclared = [k for k in given if not node.has_parameter(k)]
            assert undeclared == [], f'{graph}.yaml: {key} does not declare {undeclared}'
            for k, v in given.items():
                assert node.get_parameter(k).value == v, (key, k)
