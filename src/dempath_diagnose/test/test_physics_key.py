"""The library key follows what a scene's files hold, not where they lie (another clone)."""

from __future__ import annotations

import shutil
from pathlib import Path

from dempath_diagnose.library.simulator import load_scene, physics_key


def _copy_scene(tmp: Path, mesh_bytes: bytes | None = None) -> Path:
    scene = load_scene('builtin:tiny')
    mesh = tmp / 'tool.stl'
    shutil.copy(str(scene.tool.mesh), mesh)
    if mesh_bytes is not None:
        mesh.write_bytes(mesh_bytes)
    text = Path(str(scene.source)).read_text()
    lines = [f'  mesh: {mesh}' if line.strip().startswith('mesh:') else line
             for line in text.splitlines()]
    path = tmp / 'tiny.yaml'
    path.write_text('\n'.join(lines) + '\n')
    return path


def test_same_scene_elsewhere_keeps_its_key(tmp_path: Path) -> None:
    shipped = load_scene('builtin:tiny')
    moved = load_scene(str(_copy_scene(tmp_path)))
    assert str(moved.tool.mesh) != str(shipped.tool.mesh)
    assert physics_key(moved) == physics_key(shipped)


def test_another_tool_changes_the_key(tmp_path: Path) -> None:
    shipped = load_scene('builtin:tiny')
    data = Path(str(shipped.tool.mesh)).read_bytes()
    other = load_scene(str(_copy_scene(tmp_path, b'x' + data[1:])))  # another 80-byte header
    assert physics_key(other) != physics_key(shipped)
