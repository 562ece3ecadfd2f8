"""Tests of the clicker's core: click store, CSV files, frame sources and their bad inputs."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from dempath.bagio import write_bag
from dempath.typestore import make_typestore
from dempath_recon.clicker.click_csv import (
    Click,
    ClickBounds,
    clicks_to_csv,
    parse_markers,
    read_clicks_text,
)
from dempath_recon.clicker.clicks import ClickStore
from dempath_recon.clicker.frames import open_frames
from dempath_recon.clicker.playback import click_frames, frame_stamps
from dempath_recon.errors import ClickError

BOUNDS = ClickBounds(10, {'cam_side': (640, 480), 'cam_front': (640, 480)},
                     frozenset(range(1, 16)))


def jpeg(width: int, height: int, value: int = 100) -> bytes:
    """A flat grey JPEG of the given size."""
    ok, data = cv2.imencode('.jpg', np.full((height, width, 3), value, np.uint8))
    assert ok
    return bytes(data)


def image_bag(path: Path, cameras: dict[str, list[float]], size: tuple[int, int] = (64, 48)
              ) -> Path:
    """A bag of CompressedImage per camera at the given stamps [s]."""
    store = make_typestore()
    image_cls = store.types['sensor_msgs/msg/CompressedImage']
    header_cls, time_cls = store.types['std_msgs/msg/Header'], store.types[
        'builtin_interfaces/msg/Time']
    messages = []
    for camera, stamps in cameras.items():
        for t in stamps:
            sec = int(t)
            msg = image_cls(header=header_cls(stamp=time_cls(sec=sec, nanosec=round((t - sec)
                                                                                     * 1e9)),
                                              frame_id=camera),
                            format='jpeg', data=np.frombuffer(jpeg(*size), np.uint8))
            messages.append((f'/{camera}/image_raw/compressed', 'sensor_msgs/msg/CompressedImage',
                             round(t * 1e9), msg))
    return write_bag(path, sorted(messages, key=lambda m: m[2]), typestore=store)


def test_store_saves_after_every_click_and_undo_reverts(tmp_path: Path) -> None:
    """Each change is on disk at once; undo reverts a move, a new point and an import whole."""
    store = ClickStore(tmp_path / 'c.csv', BOUNDS)
    store.set(Click(0, 'cam_side', 1, 10.25, 20.5))
    assert read_clicks_text((tmp_path / 'c.csv').read_text(), BOUNDS, 'c') == [
        Click(0, 'cam_side', 1, 10.25, 20.5)]
    store.set(Click(0, 'cam_side', 1, 11.0, 21.0))
    store.apply([((1, 'cam_front', 2), (5.0, 6.0)), ((1, 'cam_front', 3), (7.0, 8.0))])
    assert len(store.clicks()) == 3
    assert store.undo() and len(store.clicks()) == 1
    assert store.undo() and store.clicks() == [Click(0, 'cam_side', 1, 10.25, 20.5)]
    assert store.undo() and store.clicks() == [] and not store.undo()
    assert (tmp_path / 'c.csv').read_text() == 'frame,camera,marker,x,y\n'
    assert not list(tmp_path.glob('.c.csv.*')), 'a temporary file was left behind'


def test_store_resumes_its_file(tmp_path: Path) -> None:
    """A new session on the same click file starts with its clicks."""
    clicks = [Click(3, 'cam_front', 7, 100.5, 200.25), Click(0, 'cam_side', 1, 1.0, 2.0)]
    (tmp_path / 'c.csv').write_text(clicks_to_csv(clicks))
    store = ClickStore(tmp_path / 'c.csv', BOUNDS)
    assert store.load() == 2
    assert store.clicks() == sorted(clicks, key=lambda c: c.key)


@pytest.mark.parametrize(('row', 'problem'), [
    ('0,cam_side,42,10,10', 'line 3: marker 42 is not one of the markers 1-15'),
    ('0,cam_side,2,640,10', 'line 3: point (640, 10) px is outside the 640x480 image'),
    ('0,cam_side,2,10,-3', 'line 3: point (10, -3) px is outside the 640x480 image'),
    ('12,cam_side,2,10,10', 'line 3: frame 12 is not in 0..9'),
    ('0,cam_top,2,10,10', "line 3: camera 'cam_top' is not one of cam_side, cam_front"),
    ('0,cam_side,two,10,10', 'line 3: not a click row'),
])
def test_bad_click_csv_is_refused_whole(row: str, problem: str) -> None:
    """A click CSV with an unknown marker or an out-of-image point: one line, nothing taken."""
    text = f'frame,camera,marker,x,y\n0,cam_side,1,5,5\n{row}\n'
    with pytest.raises(ClickError, match=r'^clicks\.csv: ' + problem.replace('(', r'\(')
                       .replace(')', r'\)')) as err:
        read_clicks_text(text, BOUNDS, 'clicks.csv')
    assert '\n' not in str(err.value)


def test_paper_per_particle_csvs() -> None:
    """Per-particle tables: X,Y of one camera (named in the file) or xs,ys,xf,yf of both."""
    one = read_clicks_text('image,X,Y\nframe_0002.png,10.5,20.5\nframe_0003.png,11,21\n',
                           BOUNDS, 'particle_7_front.csv')
    assert one == [Click(2, 'cam_front', 7, 10.5, 20.5), Click(3, 'cam_front', 7, 11.0, 21.0)]
    both = read_clicks_text('xs,ys,xf,yf\n1,2,3,4\n5,6,,\n', BOUNDS, 'p12.csv')
    assert both == [Click(0, 'cam_side', 12, 1.0, 2.0), Click(0, 'cam_front', 12, 3.0, 4.0),
                    Click(1, 'cam_side', 12, 5.0, 6.0)]
    with pytest.raises(ClickError, match='names its camera in the file name'):
        read_clicks_text('X,Y\n1,2\n', BOUNDS, 'particle_3.csv')
    with pytest.raises(ClickError, match=r'^particle\.csv: no marker number'):
        read_clicks_text('X,Y\n1,2\n', BOUNDS, 'particle.csv')


def test_parse_markers() -> None:
    """Marker lists as ranges and numbers."""
    assert parse_markers('1-3,7') == frozenset({1, 2, 3, 7})
    with pytest.raises(ValueError, match='markers: expected'):
        parse_markers('one')


def test_folder_of_two_cameras_pairs_by_name(tmp_path: Path) -> None:
    """cam_side/ and cam_front/ sub-folders: frame k is the k-th image of each."""
    for camera in ('cam_front', 'cam_side'):
        (tmp_path / camera).mkdir()
        for k in range(3):
            (tmp_path / camera / f'{k:03d}.jpg').write_bytes(jpeg(80, 60, 50 * k))
    frames = open_frames(tmp_path, fps=25.0)
    assert frames.cameras == ('cam_side', 'cam_front') and frames.warnings == []
    assert frames.sizes == {'cam_side': (80, 60), 'cam_front': (80, 60)}
    assert [f['cam_front'].stamp_s for f in frames.frames] == [0.0, 0.04, 0.08]  # type: ignore


def test_folder_of_mixed_sizes_is_refused(tmp_path: Path) -> None:
    """A folder of images with mixed sizes: one line naming the odd file and both sizes."""
    for k, size in enumerate([(80, 60), (80, 60), (64, 48)]):
        (tmp_path / f'{k:03d}.jpg').write_bytes(jpeg(*size))
    with pytest.raises(ClickError, match=r'002\.jpg: 64x48 px, but the other images of .* are '
                       r'80x60 px'):
        open_frames(tmp_path)


def test_bag_pairs_unsynchronised_cameras_by_stamp(tmp_path: Path) -> None:
    """The front camera, 4 ms late and missing one frame, pairs by nearest stamp."""
    side = [10.0 + k / 50 for k in range(5)]
    front = [t + 0.004 for k, t in enumerate(side) if k != 2]
    frames = open_frames(image_bag(tmp_path / 'bag', {'cam_side': side, 'cam_front': front}))
    assert len(frames.frames) == 5 and frames.frames[2]['cam_front'] is None
    stamps = frame_stamps(frames)
    assert stamps[(3, 'cam_front')] == pytest.approx(side[3] + 0.004)
    grouped = click_frames([Click(3, 'cam_front', 2, 1.0, 2.0), Click(3, 'cam_side', 1, 3.0, 4.0),
                            Click(3, 'cam_front', 1, 5.0, 6.0)], stamps)
    assert [(g.camera, g.ids.tolist()) for g in grouped] == [('cam_front', [1, 2]),
                                                             ('cam_side', [1])]
    assert grouped[0].stamp_s == pytest.approx(side[3] + 0.004)


def test_bag_with_one_camera_works_with_a_warning(tmp_path: Path) -> None:
    """A bag with only one camera opens, with one warning line saying 3D needs both."""
    frames = open_frames(image_bag(tmp_path / 'bag', {'cam_front': [1.0, 1.02]}))
    assert frames.cameras == ('cam_front',)
    assert frames.warnings == [f'{tmp_path / "bag"}: only one camera (cam_front): its clicks '
                               'are saved, but 3D needs both']


def test_source_without_images_is_an_error(tmp_path: Path) -> None:
    """A folder with no image and a missing path give one line each."""
    with pytest.raises(ClickError, match=r'no images \(\.jpg, \.png, \.\.\.\)'):
        open_frames(tmp_path)
    with pytest.raises(ClickError, match='no such bag or folder'):
        open_frames(tmp_path / 'nope')


def test_raw_image_bag_is_shown_losslessly(tmp_path: Path) -> None:
    """sensor_msgs/Image rgb8 frames are served as PNG with the same pixels (BGR order)."""
    store = make_typestore()
    image_cls, header_cls, time_cls = (store.types[t] for t in (
        'sensor_msgs/msg/Image', 'std_msgs/msg/Header', 'builtin_interfaces/msg/Time'))
    rgb = np.random.default_rng(0).integers(0, 255, (6, 8, 3), dtype=np.uint8)
    messages = [(f'/{cam}/image_raw', 'sensor_msgs/msg/Image', 10**9 + k, image_cls(
        header=header_cls(stamp=time_cls(sec=1, nanosec=k), frame_id=cam), height=6, width=8,
        encoding='rgb8', is_bigendian=0, step=24, data=rgb.ravel()))
        for k, cam in enumerate(('cam_side', 'cam_front'))]
    frames = open_frames(write_bag(tmp_path / 'raw', messages, typestore=store))
    image = frames.frames[0]['cam_front']
    assert image is not None and image.mime == 'image/png'
    shown = cv2.imdecode(np.frombuffer(image.data, np.uint8), cv2.IMREAD_COLOR)
    np.testing.assert_array_equal(shown, rgb[..., ::-1])
