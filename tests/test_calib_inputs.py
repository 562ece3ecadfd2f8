"""Calibration inputs: the shipped twin bag, two videos, a frame folder, and broken inputs."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from dempath_calib.board import PAPER_BOARD, CornerDetector
from dempath_calib.camera import StereoCalibration
from dempath_calib.cli import calibrate_main
from dempath_calib.errors import InputSourceError
from dempath_calib.sources import BagSource, FolderSource, open_source, read_timestamps_csv
from dempath_twin.board.bag import write_twin_videos
from dempath_twin.board.recording import calibration_poses, render_views
from dempath_twin.rig import paper_rig

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = ROOT / 'bags' / 'calib_twin_small'


def test_shipped_twin_bag() -> None:
    """bags/calib_twin_small: 20 JPEG frames per camera, 1920x1080, truth = paper_rig()."""
    src = open_source([str(SHIPPED)])
    assert isinstance(src, BagSource) and src.count() == 40
    cam, stamp, image = next(src.frames())
    assert cam == 0 and stamp == pytest.approx(1.0) and image.shape == (1080, 1920)
    truth = json.loads((ROOT / 'bags' / 'calib_twin_small.truth.json').read_text())
    rig = StereoCalibration.from_dict(truth['rig'])
    for a, b in zip(rig.cameras, paper_rig().cameras, strict=True):
        np.testing.assert_allclose(a.K, b.K)
        np.testing.assert_allclose(a.t, b.t)


def test_two_videos_with_delay(tmp_path: Path) -> None:
    """Two MP4s: the front one starts 2 frames late; stamps come from the frame rate."""
    side, front = write_twin_videos(tmp_path, n_keys=2, steps=6, front_delay_frames=2,
                                    fps=10.0, scale=0.5)
    frames = list(open_source([str(side), str(front)]).frames())
    cams = [f[0] for f in frames]
    assert cams.count(0) == 6 and cams.count(1) == 4
    assert [f[1] for f in frames if f[0] == 1] == pytest.approx([0.0, 0.1, 0.2, 0.3])
    det = CornerDetector(PAPER_BOARD)
    found = [(~np.isnan(det.detect(f[2])[:, 0])).sum() for f in frames]
    assert np.mean(np.array(found) >= 12) >= 0.8, found


def test_frame_folder_with_stamps(tmp_path: Path) -> None:
    """A folder with cam_side/ and cam_front/ PNGs and stamps.csv yields their stamps."""
    for i, images in enumerate(render_views(calibration_poses(5, seed=4)[3:], seed=4)):
        for cam, img in zip(('cam_side', 'cam_front'), images, strict=True):
            (tmp_path / cam).mkdir(exist_ok=True)
            cv2.imwrite(str(tmp_path / cam / f'{i:03d}.png'), img)
    for cam in ('cam_side', 'cam_front'):
        (tmp_path / cam / 'stamps.csv').write_text('file,stamp_s\n000.png,5.0\n001.png,5.5\n')
    src = open_source([str(tmp_path)])
    assert isinstance(src, FolderSource) and src.count() == 4
    got = [(c, s) for c, s, _ in src.frames()]
    assert got == [(0, 5.0), (0, 5.5), (1, 5.0), (1, 5.5)]


def test_timestamps_csv(tmp_path: Path) -> None:
    """Caliscope-style timestamps split by camera id, in time order."""
    path = tmp_path / 't.csv'
    path.write_text('sync_index,cam_id,frame_time\n1,1,2.5\n1,0,2.4\n0,0,2.2\n0,1,2.3\n')
    assert read_timestamps_csv(path) == ([2.2, 2.4], [2.3, 2.5])
    path.write_text('a,b\n1,2\n')
    with pytest.raises(InputSourceError, match='cam_id'):
        read_timestamps_csv(path)


@pytest.mark.parametrize('kind', ['corrupt_bag', 'not_video', 'empty_folder'])
def test_broken_inputs_one_error_line(tmp_path: Path, kind: str,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    """A corrupt bag, a fake video or an empty folder: exit 1 with one `error:` line."""
    if kind == 'corrupt_bag':
        bag = tmp_path / 'bag'
        bag.mkdir()
        (bag / 'metadata.yaml').write_text('rosbag2_bagfile_information: {version: 9}\n')
        (bag / 'bag.mcap').write_bytes(b'\x89MCAP0\r\n' + b'\x00' * 40)
        argv = [str(bag)]
    elif kind == 'not_video':
        for name in ('a.mp4', 'b.mp4'):
            (tmp_path / name).write_text('not a video')
        argv = [str(tmp_path / 'a.mp4'), str(tmp_path / 'b.mp4')]
    else:
        (tmp_path / 'frames').mkdir()
        argv = [str(tmp_path / 'frames')]
    assert calibrate_main([*argv, '--out', str(tmp_path / 'out')]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith('error: '), err
