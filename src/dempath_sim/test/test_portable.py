"""A portable scene carries its tool mesh and cached beds to a worker without the client's disk."""

from __future__ import annotations

from pathlib import Path

import pytest

from dempath_sim.runs.bed import packing_key
from dempath_sim.runs.portable import bed_cache_file, pack_scene
from dempath_sim.scene import SceneError, resolve_scene


def test_pack_and_unpack_elsewhere(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Mesh and the seed's bed arrive byte for byte; the unpacked scene reads them; the packing
    key (the bed the run looks up) is the same on both sides."""
    scene = resolve_scene('tiny')
    client_cache = tmp_path / 'client' / 'packings'
    seeded = scene.with_overrides(seed=1001)
    bed_name = f'{packing_key(seeded, seeded.bed_model())}.npz'
    client_cache.mkdir(parents=True)
    (client_cache / bed_name).write_bytes(b'settled bed of seed 1001')
    portable = pack_scene(scene, (1001, 1002), client_cache)
    assert list(portable.beds) == [bed_name]  # seed 1002 was never poured: the worker pours it

    (tmp_path / 'worker' / 'tmp').mkdir(parents=True)
    monkeypatch.setenv('TMPDIR', str(tmp_path / 'worker' / 'tmp'))
    import tempfile

    monkeypatch.setattr(tempfile, 'tempdir', None)
    worker_cache = tmp_path / 'worker' / 'packings'
    there = portable.unpack(worker_cache)
    assert there.tool.mesh != scene.tool.mesh
    assert str(there.tool.mesh).startswith(str(tmp_path / 'worker'))
    assert there.tool.mesh.read_bytes() == Path(scene.tool.mesh).read_bytes()
    assert (worker_cache / bed_name).read_bytes() == b'settled bed of seed 1001'
    there_seeded = there.with_overrides(seed=1001)
    assert bed_cache_file(there_seeded, worker_cache) == worker_cache / bed_name
    assert portable.unpack(worker_cache) == there  # a second task on the worker writes nothing


def test_missing_mesh_is_named(tmp_path: Path) -> None:
    """A scene whose tool mesh cannot be read is refused on the client, naming the file."""
    from dataclasses import replace

    scene = resolve_scene('tiny')
    gone = replace(scene, tool=replace(scene.tool, mesh=tmp_path / 'gone.stl'))
    with pytest.raises(SceneError, match=r'gone\.stl: cannot read the tool mesh'):
        pack_scene(gone)
