"""Default topic names of the dempath graph, in one place so that nodes, bags and tests agree."""

from __future__ import annotations

CAMERAS = ('cam_side', 'cam_front')  # Cam 1 (side) and Cam 2 (front) of the paper

IMAGE_RAW = '/{camera}/image_raw'  # sensor_msgs/Image
IMAGE_COMPRESSED = '/{camera}/image_raw/compressed'  # sensor_msgs/CompressedImage
CAMERA_INFO = '/{camera}/camera_info'  # sensor_msgs/CameraInfo, transient local
PIXEL_POINTS = '/{camera}/pixel_points'  # dempath_msgs/PixelPoints

MARKER_POINTS = '/markers/points3d'  # dempath_msgs/MarkerPoints3D
MARKER_VIZ = '/markers/visualization'  # visualization_msgs/MarkerArray

SIM_STATES = '/sim/particle_states'  # dempath_msgs/ParticleStates
SIM_TOOL_FORCE = '/sim/tool_force'  # dempath_msgs/ToolForce
SIM_TOOL_POSE = '/sim/tool_pose'  # geometry_msgs/PoseStamped
SIM_TOOL_WRENCH = '/sim/tool_wrench'  # geometry_msgs/WrenchStamped (the force, standard type)
SIM_CLOUD = '/sim/particles'  # sensor_msgs/PointCloud2: x, y, z, radius, marker_id
SIM_RUN_EVENTS = '/sim/run_events'  # dempath_msgs/RunEvent
SIM_VIZ = '/sim/visualization'  # visualization_msgs/MarkerArray

COMPARE_SCORES = '/compare/scores'  # dempath_msgs/TrajectoryScoreArray
COMPARE_VIZ = '/compare/visualization'  # visualization_msgs/MarkerArray
DIAGNOSIS = '/diagnosis'  # dempath_msgs/Diagnosis

CLOCK = '/clock'  # rosgraph_msgs/Clock, published by the player

# Live rig (docs/live.md): the tool's pose from the tractor (geometry_msgs/PoseStamped), pass
# start/end from a controller or button (RunEvent), and the measured passes found from either
TOOL_POSE = '/tool/pose'
TOOL_EVENTS = '/tool/events'
PASS_EVENTS = '/markers/pass_events'  # dempath_msgs/RunEvent, transient local
DIAGNOSTICS = '/diagnostics'  # diagnostic_msgs/DiagnosticArray: counts, drops, latency


def camera_topic(template: str, camera: str) -> str:
    """Fill a per-camera topic template, e.g. ``camera_topic(IMAGE_RAW, 'cam_side')``."""
    return template.format(camera=camera)

# dempath_msgs/RunEvent from the player, transient local: STARTED, then FINISHED or ABORTED
PLAYER_EVENTS = '/player/events'


def dempath_namespaces() -> tuple[str, ...]:
    """The first-level namespaces of every dempath topic (``/cam_side``, ``/sim``, ...).

    The recorder records every topic under these namespaces when no topic list is given; ``/clock``
    is not among them.
    """
    names = [camera_topic(t, c) for t in (IMAGE_RAW, PIXEL_POINTS) for c in CAMERAS]
    names += [MARKER_POINTS, SIM_STATES, COMPARE_SCORES, DIAGNOSIS, PLAYER_EVENTS]
    return tuple(dict.fromkeys('/' + n.split('/')[1] for n in names))


def is_dempath_topic(topic: str) -> bool:
    """Whether ``topic`` lies under one of :func:`dempath_namespaces` (or is one of them)."""
    return any(topic == ns or topic.startswith(ns + '/') for ns in dempath_namespaces())

# dempath_msgs/RunEvent from the clicker node, transient local: STARTED, then FINISHED
CLICKER_EVENTS = '/clicker/events'
