"""``dempath frames``: the frames file a launch's recorder reads, and its one-line errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dempath.frames import check_tree, load_frames
from dempath_bringup.framescli import frames_main
from dempath_twin.rig import paper_rig


def test_frames_file_of_the_twin_rig(tmp_path: Path) -> None:
    """The written tree reaches world; each camera sits where the calibration puts it."""
    rig = paper_rig()
    out = tmp_path / 'frames.yaml'
    assert frames_main(['--calibration', str(rig.save(tmp_path / 'stereo.yaml')),
                        '--scene', 'tiny', '--out', str(out)]) == 0
    frames = load_frames(out)
    assert check_tree(frames) == {'scene': 'world', 'field': 'scene',
                                  'cam_side_optical': 'field', 'cam_front_optical': 'field'}
    pose = {t.child: t for t in frames}
    for cam in rig.cameras:
        np.testing.assert_allclose(pose[f'{cam.name}_optical'].translation, cam.center,
                                   atol=1e-9)


def test_bad_calibration_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A missing calibration: exit 1, one ``error:`` line naming it, no file written."""
    out = tmp_path / 'frames.yaml'
    assert frames_main(['--calibration', str(tmp_path / 'none.yaml'), '--scene', 'tiny',
                        '--out', str(out)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith('error: ') and 'none.yaml' in err[0]
    assert not out.exists()
