"""The clicker node, launch-free: a click file -> PixelPoints (SOURCE_CLICKED) -> 3D points."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dempath import topics
from dempath_msgs.msg import MarkerPoints3D, PixelPoints, RunEvent
from dempath_recon.clicker.click_csv import Click, clicks_to_csv
from dempath_recon.errors import ClickError
from dempath_recon.nodes.clicker import ClickerNode
from dempath_recon.nodes.reconstructor import ReconstructorNode
from dempath_twin.rig import sample_working_volume


def test_clicks_flow_through_the_reconstructor(ros_harness, rig, tmp_path: Path) -> None:
    """Clicked pixels of 3 frames x 4 markers come out as the exact 3D points."""
    truth = sample_working_volume(12, np.random.default_rng(7)).reshape(3, 4, 3)
    clicks = [Click(k, cam.name, m, float(u), float(v))
              for k in range(3) for cam in rig.cameras
              for m, (u, v) in zip((1, 2, 3, 4), cam.project(truth[k]), strict=True)]
    (tmp_path / 'clicks.csv').write_text(clicks_to_csv(clicks))
    ros_harness.start(ReconstructorNode, method='dlt', slop=0.005,
                      calibration_file=str(rig.save(tmp_path / 'calib.yaml')))
    points = ros_harness.collect(MarkerPoints3D, topics.MARKER_POINTS)
    pixels = ros_harness.collect(PixelPoints, topics.camera_topic(topics.PIXEL_POINTS,
                                                                  'cam_front'))
    events = ros_harness.collect(RunEvent, topics.CLICKER_EVENTS)
    node = ros_harness.start(ClickerNode, clicks_file=str(tmp_path / 'clicks.csv'),
                             wait_for_subscribers=2, rate_hz=20.0)
    assert ros_harness.spin_until(lambda: len(points) == 3 and len(events) == 2, 15.0), \
        (len(points), len(events))
    assert [e.event for e in events] == [RunEvent.STARTED, RunEvent.FINISHED]
    assert node.published == 24
    assert all(list(p.source) == [PixelPoints.SOURCE_CLICKED] * 4 for p in pixels)
    assert [p.header.stamp.nanosec for p in pixels] == [0, 20_000_000, 40_000_000]
    for k, msg in enumerate(points):
        assert list(msg.marker_ids) == [1, 2, 3, 4]
        assert np.abs(np.column_stack([msg.x, msg.y, msg.z]) - truth[k]).max() < 1e-6


def test_clicker_node_refuses_a_bad_click_file(ros_harness, tmp_path: Path) -> None:
    """A click file with an unknown marker stops the node with one line naming file and line."""
    (tmp_path / 'c.csv').write_text('frame,camera,marker,x,y\n0,cam_side,16,1,1\n')
    with pytest.raises(ClickError, match=r'c\.csv: line 2: marker 16 is not one of the '
                       r'markers 1-15'):
        ros_harness.start(ClickerNode, clicks_file=str(tmp_path / 'c.csv'))
