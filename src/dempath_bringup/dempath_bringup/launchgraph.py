"""The node graphs that ``ros2 launch dempath_bringup <graph>.launch.py`` starts, as data.

The launch files (``launch/field_replay.launch.py``, ``launch/live.launch.py``) turn these specs
into ``launch_ros`` Node actions with the graph's parameter file (``config/<graph>.yaml``) and
the launch arguments (bag, calibration, scene, output...). Keeping the graph here, in plain
Python, lets the tests check it where ``launch`` is not installed (it is not on the package
index): every executable is a console script of its package, and every parameter in the YAML is
one the node declares (tests/test_launch_graph.py).

``field_replay``: a recorded field bag (images of both cameras) -> one detector per camera ->
reconstructor; the model run (simulator) and the comparer scoring it; the recorder recording
every topic with the frames (``/tf_static``, ``/tf``). The same graph ``dempath demo`` runs in
one process (``nodes/graph.py``). ``live``: camera drivers (not started here) -> detectors ->
reconstructor; ``dempath_pass`` finds the passes from the tool's pose; the recorder records.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class LaunchArgument:
    """A ``ros2 launch`` argument (``name:=value``)."""

    name: str
    default: str
    description: str


@dataclass(frozen=True)
class NodeSpec:
    """One node of a graph.

    Attributes:
        package: ROS package holding the executable.
        executable: console script in ``lib/<package>``.
        namespace: '' or the camera's namespace (two detectors of one class).
        arguments: (parameter, launch argument) pairs: the argument's value overrides the YAML.
    """

    package: str
    executable: str
    namespace: str = ''
    arguments: tuple[tuple[str, str], ...] = ()

    @property
    def yaml_key(self) -> str:
        """The node's key in the parameter file: ``/<namespace>/<name>`` or ``<name>``."""
        return f'/{self.namespace}/{self.executable}' if self.namespace else self.executable


CALIBRATION = LaunchArgument('calibration', '', 'stereo calibration YAML (dempath calibrate)')
OUTPUT = LaunchArgument('output', 'dempath_bag', 'bag directory the recorder creates')
FRAMES = LaunchArgument('frames', '', "static frames YAML for /tf_static (dempath.frames); ''")
SCENE = LaunchArgument('scene', 'reduced_1ms', 'scene file or shipped scene name')

ARGUMENTS: dict[str, tuple[LaunchArgument, ...]] = {
    'field_replay': (LaunchArgument('bag', '', 'recorded field bag (both cameras)'),
                     CALIBRATION, SCENE, OUTPUT, FRAMES,
                     LaunchArgument('rate', '0.25', 'playback speed factor')),
    'live': (CALIBRATION, SCENE, OUTPUT, FRAMES),
}


def _detectors(arguments: tuple[tuple[str, str], ...]) -> tuple[NodeSpec, ...]:
    return tuple(NodeSpec('dempath_recon', 'dempath_detector', cam, arguments)
                 for cam in ('cam_side', 'cam_front'))


GRAPHS: dict[str, tuple[NodeSpec, ...]] = {
    'field_replay': (
        NodeSpec('dempath', 'dempath_player', arguments=(('bag', 'bag'), ('rate', 'rate'))),
        *_detectors((('calibration_file', 'calibration'),)),
        NodeSpec('dempath_recon', 'dempath_reconstructor',
                 arguments=(('calibration_file', 'calibration'),)),
        NodeSpec('dempath_sim', 'dempath_simulator', arguments=(('scene', 'scene'),)),
        NodeSpec('dempath_compare', 'dempath_comparer'),
        NodeSpec('dempath', 'dempath_recorder',
                 arguments=(('output', 'output'), ('frames_file', 'frames'))),
    ),
    'live': (
        *_detectors((('calibration_file', 'calibration'), ('scene', 'scene'))),
        NodeSpec('dempath_recon', 'dempath_reconstructor',
                 arguments=(('calibration_file', 'calibration'),)),
        NodeSpec('dempath_recon', 'dempath_pass'),
        NodeSpec('dempath', 'dempath_recorder',
                 arguments=(('output', 'output'), ('frames_file', 'frames'))),
    ),
}
