"""The clicker used as a person would: a real headless Chromium clicks rendered markers.

Frames with shaded spheres at known sub-pixel centres (a folder of two cameras, two frames) are
served by ``dempath_recon.clicker.server``; selenium selects marker numbers, zooms with the mouse
wheel around each marker, clicks its centre, undoes a wrong click, steps to the next frame,
accepts a detection, and downloads the CSV through the page's Export link. The exported centres
must match the rendered ones within 0.5 px. ``DEMPATH_SCREENSHOTS=1`` keeps the page's
screenshot as docs/clicker.png.
"""

from __future__ import annotations

import csv
import os
import shutil
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest

from dempath.browser import BrowserNotFoundError, headless_chromium
from dempath.nodes.pytest_plugin import require_component
from dempath_recon.clicker.click_csv import ClickBounds
from dempath_recon.clicker.clicks import ClickStore
from dempath_recon.clicker.frames import open_frames
from dempath_recon.clicker.server import ClickServer, ClickSession

WIDTH, HEIGHT = 960, 540
RADIUS_PX = 6.0
# (frame, camera) -> {marker: (x, y)} px, pixel centres at integers
TRUTH = {(0, 'cam_side'): {1: (200.37, 150.81), 2: (410.62, 300.25), 3: (700.14, 95.55)},
         (0, 'cam_front'): {1: (300.71, 200.33), 2: (520.48, 410.90)},
         (1, 'cam_side'): {1: (230.20, 160.60)},
         (1, 'cam_front'): {2: (530.90, 405.15)}}
DOCS = Path(__file__).resolve().parents[1] / 'docs'


def render(markers: dict[int, tuple[float, float]], seed: int) -> np.ndarray:
    """A sand-like BGR frame with blue shaded spheres, 4x4 supersampled (centres exact)."""
    rng = np.random.default_rng(seed)
    sand = np.array([90.0, 150.0, 190.0]) + rng.normal(0, 12, (HEIGHT, WIDTH, 1))
    sub = (np.arange(4) + 0.5) / 4 - 0.5
    ys, xs = np.mgrid[0:HEIGHT, 0:WIDTH].astype(np.float64)
    image = np.repeat(sand, 1, axis=2) * np.ones(3)
    for x0, y0 in markers.values():
        cover = np.zeros((HEIGHT, WIDTH))
        shade = np.zeros((HEIGHT, WIDTH))
        for dy in sub:
            for dx in sub:
                r2 = ((xs + dx - x0) ** 2 + (ys + dy - y0) ** 2) / RADIUS_PX ** 2
                inside = r2 < 1.0
                cover += inside / 16
                shade += np.where(inside, np.sqrt(np.clip(1 - r2, 0, 1)), 0) / 16
        blue = np.stack([60 * cover + 190 * shade, 40 * cover + 60 * shade,
                         20 * cover + 30 * shade], axis=-1)
        image = image * (1 - cover[..., None]) + blue
    return np.clip(image, 0, 255).astype(np.uint8)


@pytest.fixture
def session(tmp_path: Path) -> Iterator[ClickServer]:
    """A served folder of two cameras x two frames, with detections of frame 1."""
    for (frame, camera), markers in TRUTH.items():
        (tmp_path / 'frames' / camera).mkdir(parents=True, exist_ok=True)
        cv2.imwrite(str(tmp_path / 'frames' / camera / f'{frame:04d}.png'),
                    render(markers, seed=frame))
    frames = open_frames(tmp_path / 'frames')
    store = ClickStore(tmp_path / 'clicks.csv',
                       ClickBounds(len(frames.frames), frames.sizes, frozenset(range(1, 16))))
    detections = {(1, 'cam_front'): [(2, 530.92, 405.11, 0.93)],
                  (0, 'cam_side'): [(m, x + 0.2, y - 0.1, 0.9)
                                    for m, (x, y) in TRUTH[(0, 'cam_side')].items()]}
    server = ClickServer(ClickSession(frames, store, detections), port=0)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield server
    server.shutdown()
    server.server_close()


@pytest.fixture
def browser(tmp_path: Path) -> Iterator[Any]:
    """A headless Chromium (apt-installed when missing and allowed, else the test fails)."""
    try:
        driver = headless_chromium(1500, 600, download_dir=tmp_path / 'downloads')
    except BrowserNotFoundError as err:
        require_component('chromium', err)
    yield driver
    driver.quit()


def view(driver: Any, camera: int) -> tuple[float, float, float]:
    """The page's view of a camera: (scale CSS px per image px, ox, oy)."""
    return tuple(driver.execute_script(
        'const v = clicker.views[arguments[0]]; return [v.s, v.ox, v.oy];', camera))


def at(driver: Any, camera: int, x: float, y: float) -> tuple[int, int]:
    """Where image point (x, y) of a camera shows, in viewport CSS px (rounded)."""
    s, ox, oy = view(driver, camera)
    rect = driver.execute_script(
        'return document.getElementById(arguments[0]).getBoundingClientRect().toJSON();',
        f'canvas{camera}')
    return round(rect['left'] + (x + 0.5 - ox) * s), round(rect['top'] + (y + 0.5 - oy) * s)


def zoom_at(driver: Any, camera: int, x: float, y: float, steps: int) -> None:
    """Turn the mouse wheel up ``steps`` times over image point (x, y)."""
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.actions.wheel_input import ScrollOrigin

    for _ in range(steps):
        ActionChains(driver).scroll_from_origin(
            ScrollOrigin.from_viewport(*at(driver, camera, x, y)), 0, -260).perform()


def click_marker(driver: Any, camera: int, marker: int, x: float, y: float) -> None:
    """Choose the marker number, zoom in around the marker with the wheel, click its centre."""
    from selenium.webdriver.common.actions.action_builder import ActionBuilder
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import Select

    Select(driver.find_element(By.ID, 'marker')).select_by_value(str(marker))
    driver.find_element(By.ID, 'fit').click()
    zoom_at(driver, camera, x, y, steps=5)  # about 13x
    assert view(driver, camera)[0] > 5.0, 'the wheel did not zoom in'
    n_before = driver.execute_script('return clicker.updates;')
    actions = ActionBuilder(driver)
    actions.pointer_action.move_to_location(*at(driver, camera, x, y)).click()
    actions.perform()
    wait(driver, lambda: driver.execute_script('return clicker.updates;') > n_before)


def wait(driver: Any, condition: Any, timeout_s: float = 10.0) -> None:
    """Poll ``condition()`` until true."""
    deadline = time.monotonic() + timeout_s
    while not condition():
        assert time.monotonic() < deadline, 'the page did not update'
        time.sleep(0.05)


def test_browser_clicks_match_rendered_centres(session: ClickServer, browser: Any,
                                               tmp_path: Path) -> None:
    """Clicks placed with zoom in a real browser export within 0.5 px of the rendered centres."""
    from selenium.webdriver.common.by import By

    driver = browser
    driver.get(session.url)
    wait(driver, lambda: driver.execute_script('return window.clicker && clicker.ready === true;'))
    for camera, name in enumerate(('cam_side', 'cam_front')):
        for marker, (x, y) in TRUTH[(0, name)].items():
            click_marker(driver, camera, marker, x, y)
    click_marker(driver, 0, 3, 650.0, 120.0)  # a wrong click moves marker 3 ...
    click_marker(driver, 0, 4, 100.0, 100.0)  # ... and marker 4 is not even there
    for _ in range(2):
        driver.find_element(By.ID, 'undo').click()
        time.sleep(0.3)
    driver.find_element(By.ID, 'next').click()
    wait(driver, lambda: driver.execute_script('return clicker.data.frame;') == 1)
    click_marker(driver, 0, 1, *TRUTH[(1, 'cam_side')][1])
    driver.find_element(By.ID, 'accept').click()  # the front camera's detection of marker 2
    wait(driver, lambda: len(driver.execute_script('return clicker.data.clicks;')) == 2)
    driver.find_element(By.ID, 'first').click()
    driver.find_element(By.ID, 'fit').click()
    wait(driver, lambda: driver.execute_script('return clicker.data.frame;') == 0)
    zoom_at(driver, 0, *TRUTH[(0, 'cam_side')][2], steps=3)  # for the screenshot
    time.sleep(0.5)
    driver.save_screenshot(str(tmp_path / 'clicker.png'))
    if os.environ.get('DEMPATH_SCREENSHOTS') == '1':
        shutil.copy(tmp_path / 'clicker.png', DOCS / 'clicker.png')
    driver.find_element(By.ID, 'export').click()
    exported = tmp_path / 'downloads' / 'clicks.csv'
    wait(driver, exported.is_file)
    rows = list(csv.DictReader(exported.open()))
    assert exported.read_text() == (tmp_path / 'clicks.csv').read_text()
    got = {(int(r['frame']), r['camera'], int(r['marker'])): (float(r['x']), float(r['y']))
           for r in rows}
    want = {(f, c, m): xy for (f, c), markers in TRUTH.items() for m, xy in markers.items()}
    want[(1, 'cam_front', 2)] = (530.92, 405.11)  # accepted detection, as detected
    assert set(got) == set(want), f'clicked {sorted(got)}'
    errors = np.array([np.subtract(got[k], want[k]) for k in sorted(want)])
    assert np.abs(errors).max() < 0.5, f'largest click error {np.abs(errors).max():.3f} px'
