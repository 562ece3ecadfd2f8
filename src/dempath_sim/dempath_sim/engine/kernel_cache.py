"""numba's on-disk kernel cache, kept in step with the kernel sources of the engine.

numba keys a cached kernel on its own file only; the kernels in ``engine/`` inline the laws of
``engine/laws/``, so the engine calls :func:`refresh_own_kernel_cache` on import to drop a
cache built from other sources. The digest covers every kernel module under ``engine/``
(sub-packages included) and each directory's numba cache is refreshed.
"""

from __future__ import annotations

import hashlib
import logging
import os
from pathlib import Path

from dempath_sim.engine.boundary import boundary_forces
from dempath_sim.engine.laws.hertz_mindlin import hertz_mindlin

logger = logging.getLogger(__name__)

# Name of the file holding the digest of the kernel sources a numba cache was built from.
KERNEL_STAMP = 'dempath_sim_kernels.sha1'


def kernel_source_digest(package_dir: Path) -> str:
    """SHA-1 of the modules under package_dir (recursively) that hold numba kernels.

    A module holds kernels when its text contains 'njit'; each is hashed with its path
    relative to package_dir, so moving a kernel module changes the digest too.
    """
    root = Path(package_dir)
    sha = hashlib.sha1()
    for path in sorted(root.rglob('*.py')):
        text = path.read_bytes()
        if b'njit' in text:
            sha.update(path.relative_to(root).as_posix().encode() + b'\0' + text)
    return sha.hexdigest()


def refresh_kernel_cache(cache_dir: Path, package_dir: Path, digest: str) -> int:
    """Remove numba's cached kernels of the package from cache_dir if built from other sources.

    numba keys a cached kernel on its own file's modification time and size only, so a kernel
    that inlines a law from another module (boundary.py and pair_forces.py inline
    laws/hertz_mindlin.py) would keep running the old law after that module changed. The
    stamp file KERNEL_STAMP holds the digest the cache was built from; on a mismatch the index
    and data files of the package's modules are removed, so numba compiles afresh.

    Args:
        cache_dir: numba's cache directory of the package's kernels.
        package_dir: Directory of the modules whose cache files are removed (this directory
            only: numba keeps one cache directory per source directory).
        digest: `kernel_source_digest` of the current sources.

    Returns:
        Number of cache files removed.
    """
    stamp = Path(cache_dir) / KERNEL_STAMP
    if not Path(cache_dir).is_dir() or (stamp.is_file() and stamp.read_text() == digest):
        return 0
    modules = {p.stem for p in Path(package_dir).glob('*.py')}
    removed = 0
    for path in Path(cache_dir).iterdir():
        if path.suffix in ('.nbi', '.nbc') and path.name.split('.', 1)[0] in modules:
            path.unlink(missing_ok=True)
            removed += 1
    tmp = stamp.with_suffix(f'.{os.getpid()}.tmp')
    tmp.write_text(digest)
    tmp.replace(stamp)
    return removed


# One compiled function per directory holding kernels: numba keeps one cache per directory.
_KERNELS_BY_DIRECTORY = (boundary_forces, hertz_mindlin)


def refresh_own_kernel_cache() -> None:
    """`refresh_kernel_cache` for every numba cache of the engine (skipped where not writable).

    The digest covers all kernel modules under ``engine/``, so a change to a law in
    ``engine/laws/`` drops the cached kernels of ``engine/`` that inline it.
    """
    engine_dir = Path(__file__).parent
    digest = kernel_source_digest(engine_dir)
    for kernel in _KERNELS_BY_DIRECTORY:
        cache_dir = getattr(getattr(kernel, '_cache', None), '_cache_path', None)
        if cache_dir is None:
            continue
        module_dir = Path(kernel.py_func.__code__.co_filename).parent
        try:
            n = refresh_kernel_cache(Path(cache_dir), module_dir, digest)
        except OSError as exc:
            logger.debug('numba kernel cache %s not refreshed: %s', cache_dir, exc)
            continue
        if n:
            logger.info('kernel sources changed: removed %d stale numba cache files', n)

