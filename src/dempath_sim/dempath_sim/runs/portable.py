"""A scene that carries the files its run reads, for a worker that shares no disk with the client.

A run reads three kinds of file besides the scene itself: the tool's STL (``tool.mesh``), a
packing file the scene names (``fill.packing``) and the settled bed in the packing cache. On a
cluster whose workers do not see the client's folders (another host, another user, a container),
none of those paths exists on the worker. :func:`pack_scene` reads them on the client;
:meth:`PortableScene.unpack` writes them on the worker (the files into a folder of the worker's
temporary directory named by their content, the beds into the worker's own packing cache, each
atomically and only when absent) and returns the scene pointing at them. Packing keys do not
change: they hash the mesh's bytes, never its path.
"""

from __future__ import annotations

import hashlib
import tempfile
from dataclasses import dataclass, field, replace
from pathlib import Path

from dempath_sim.errors import SceneError
from dempath_sim.runs.bed import bundled_packing_dir, default_cache_dir, packing_key
from dempath_sim.scene.spec import SceneSpec

PORTABLE_DIR = 'dempath-portable'  # folder under the worker's temporary directory


def bed_cache_file(scene: SceneSpec, cache_dir: Path | None = None) -> Path | None:
    """The cached settled bed a run of ``scene`` (its seed) reads, or None when not poured yet.

    The bed is poured with ``scene.bed_model()``; the cache folder is looked up first, then the
    packings shipped with dempath.
    """
    name = f'{packing_key(scene, scene.bed_model())}.npz'
    for path in ((cache_dir or default_cache_dir()) / name, bundled_packing_dir() / name):
        if path.is_file():
            return path
    return None


def _read(path: Path, what: str) -> bytes:
    try:
        return path.read_bytes()
    except OSError as err:
        raise SceneError(f'{path}: cannot read the {what} ({err.strerror})') from err


def _write_once(path: Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically unless the file is already there."""
    if not path.is_file():
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(f'{path.name}.{hashlib.sha256(data).hexdigest()[:8]}.part')
        tmp.write_bytes(data)
        tmp.replace(path)
    return path


@dataclass(frozen=True)
class PortableScene:
    """A scene with the bytes of the files its runs read.

    Attributes:
        scene: The scene as the client reads it (its paths are the client's).
        mesh: The tool STL's bytes.
        packing: The bytes of the scene's packing file (``fill.packing``), or None.
        beds: Packing-cache file name -> bytes of the settled beds the runs read (empty when
            the worker pours them itself).
    """

    scene: SceneSpec
    mesh: bytes
    packing: bytes | None = None
    beds: dict[str, bytes] = field(default_factory=dict)

    def unpack(self, cache_dir: Path | None = None) -> SceneSpec:
        """Write the files on this machine (once) and return the scene that reads them.

        Args:
            cache_dir: This machine's packing cache (its default when None).
        """
        folder = Path(tempfile.gettempdir()) / PORTABLE_DIR
        mesh_name = f'{hashlib.sha256(self.mesh).hexdigest()[:16]}{self.scene.tool.mesh.suffix}'
        tool = replace(self.scene.tool, mesh=_write_once(folder / mesh_name, self.mesh))
        fill = self.scene.fill
        if self.packing is not None and fill.packing is not None:
            name = f'{hashlib.sha256(self.packing).hexdigest()[:16]}{Path(fill.packing).suffix}'
            fill = replace(fill, packing=_write_once(folder / name, self.packing))
        for name, data in self.beds.items():
            _write_once((cache_dir or default_cache_dir()) / name, data)
        return replace(self.scene, tool=tool, fill=fill)


def pack_scene(scene: SceneSpec, seeds: tuple[int, ...] = (),
               cache_dir: Path | None = None) -> PortableScene:
    """``scene`` with its tool mesh, packing file and the cached beds of ``seeds``.

    Args:
        scene: The scene (paths valid here, on the client).
        seeds: Seeds whose settled beds (``scene.bed_model()`` physics) travel with it; a bed
            not in the cache is left to the worker to pour, one shipped with dempath is found
            in the worker's installation.
        cache_dir: The client's packing cache (the default when None).

    Raises:
        SceneError: The tool mesh or the packing file cannot be read.
    """
    packing = None if scene.fill.packing is None else _read(Path(scene.fill.packing),
                                                            'packing file')
    beds = {}
    for seed in seeds:
        found = bed_cache_file(scene.with_overrides(seed=seed), cache_dir)
        if found is not None and found.parent != bundled_packing_dir():
            beds[found.name] = _read(found, 'cached packing')
    return PortableScene(scene, _read(Path(scene.tool.mesh), 'tool mesh'), packing, beds)


__all__ = ['PortableScene', 'bed_cache_file', 'pack_scene']
