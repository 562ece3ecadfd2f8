"""``dempath demo`` on bad inputs: one clear error line each, nothing written is lost.

A bag with only one camera and a calibration folder of images with mixed sizes stop the demo
with one ``error:`` line naming the input and the fault (exit code 1) before any long stage;
what an earlier run wrote into the output folder stays. (A camera topic that stops mid-pass is
in ``test_demo_detect.py``, Ctrl-C in ``test_demo_interrupt.py``.)
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from dempath.bagio import filter_bag
from dempath_bringup.demo import demo_main

ROOT = Path(__file__).resolve().parents[1]
RENDER = ROOT / 'bags' / 'field_render_reduced_1ms'


def error_lines(capsys: pytest.CaptureFixture[str]) -> list[str]:
    """The ``error:`` lines the command printed on stderr."""
    return [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith('error:')]


def test_bag_with_one_camera(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Only cam_side in the bag: one error line naming the bag and the missing camera."""
    bag = filter_bag(RENDER, tmp_path / 'one_cam', lambda topic, _: 'cam_front' not in topic)
    out = tmp_path / 'out'
    out.mkdir()
    (out / 'kept.txt').write_text('from an earlier run')
    code = demo_main(['--field-bag', str(bag), '--scene', 'tiny', '--out', str(out)])
    lines = error_lines(capsys)
    assert code == 1
    assert len(lines) == 1, lines
    assert 'one_cam' in lines[0] and 'cam_front' in lines[0], lines[0]
    assert (out / 'kept.txt').read_text() == 'from an earlier run'


def test_calibration_folder_with_mixed_sizes(tmp_path: Path,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    """A frame folder whose front images change size: one error line naming the fault."""
    folder = tmp_path / 'frames'
    rng = np.random.default_rng(0)
    for cam in ('cam_side', 'cam_front'):
        (folder / cam).mkdir(parents=True)
        for i in range(3):
            h, w = (270, 480) if cam == 'cam_front' and i == 2 else (540, 960)
            cv2.imwrite(str(folder / cam / f'{i:04d}.png'),
                        rng.integers(0, 255, (h, w), dtype=np.uint8))
    code = demo_main(['--field-bag', str(RENDER), '--calib-bag', str(folder), '--scene', 'tiny',
                      '--out', str(tmp_path / 'out')])
    lines = error_lines(capsys)
    assert code == 1
    assert len(lines) == 1, lines
    assert 'frames' in lines[0] and 'mixed sizes' in lines[0] and '480x270' in lines[0], lines[0]
