"""The scene a render runs when its source is a scene: effect settings reach the physics, and a
bad setting is one error line (the render's CLI, before any simulation)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest

from dempath_sim.errors import SceneError
from dempath_twin.render.bag import render_main, render_scene


def test_on_keeps_an_always_on_effect_at_its_default() -> None:
    """``--on tool_speed`` alone leaves the tool at the scene's speed (the effect is always on)."""
    scene = render_scene('tiny', [], ['tool_speed'], 65)
    assert scene.physics_model().speed_scale == 1.0
    assert scene.seed == 65


def test_effect_sets_the_tool_speed() -> None:
    """``--effect tool_speed.speed_scale=2`` drives the tool twice as fast; other effects keep
    the scene's values."""
    base = render_scene('tiny', [], [], None)
    faster = render_scene('tiny', ['tool_speed.speed_scale=2'], [], 65)
    assert faster.physics_model().speed_scale == 2.0
    assert replace(faster.physics_model(), speed_scale=1.0) == base.physics_model()


def test_a_bad_effect_setting_is_a_scene_error() -> None:
    """A setting without a number is refused by name."""
    with pytest.raises(SceneError, match=r'tool_speed\.speed_scale=fast'):
        render_scene('tiny', ['tool_speed.speed_scale=fast'], [], None)


def test_the_cli_prints_one_error_line(tmp_path: Path,
                                       capsys: pytest.CaptureFixture[str]) -> None:
    """The CLI turns a bad ``--effect`` into one ``error:`` line and exit code 1, and writes
    nothing."""
    out = tmp_path / 'bag'
    code = render_main(['tiny', '--out', str(out), '--effect', 'tool_speed=2'])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1
    assert len(err) == 1 and err[0].startswith('error: tiny: ') and 'tool_speed=2' in err[0]
    assert not out.exists()
