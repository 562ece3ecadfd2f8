"""numba's on-disk kernel cache, kept in step with the kernel sources of this package.

numba keys a cached kernel on its own file only; kernels here inline laws from other modules,
so the engine calls :func:`refresh_own_kernel_cache` on import to drop a cache built from other
sources.
"""

from __future__ import annotations

import hashlib
import logging
import os
from pathlib import Path

from dempath_sim.boundary import boundary_forces

logger = logging.getLogger(__name__)

# Name of the file holding the digest of the kernel sources a numba cache was built from.
KERNEL_STAMP = 'dempath_sim_kernels.sha1'


def kernel_source_digest(package_dir: Path) -> str:
    """SHA-1 of the package's modules that hold numba kernels (text containing 'njit')."""
    sha = hashlib.sha1()
    for path in sorted(Path(package_dir).glob('*.py')):
        text = path.read_bytes()
        if b'njit' in text:
            sha.update(path.name.encode() + b'\0' + text)
    return sha.hexdigest()


def refresh_kernel_cache(cache_dir: Path, package_dir: Path, digest: str) -> int:
    """Remove numba's cached kernels of the package from cache_dir if built from other sources.

    numba keys a cached kernel on its own file's modification time and size only, so a kernel
    that inlines a law from another module (boundary.py and pair_forces.py inline
    contact_hertz_mindlin.py) would keep running the old law after that module changed. The
    stamp file KERNEL_STAMP holds the digest the cache was built from; on a mismatch the index
    and data files of the package's modules are removed, so numba compiles afresh.

    Args:
        cache_dir: numba's cache directory of the package's kernels.
        package_dir: Directory of the package's modules (names the files to remove).
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


def refresh_own_kernel_cache() -> None:
    """`refresh_kernel_cache` for this package's numba cache (skipped where not writable)."""
    cache = getattr(boundary_forces, '_cache', None)
    cache_dir = getattr(cache, '_cache_path', None)
    if cache_dir is None:
        return
    package_dir = Path(__file__).parent
    try:
        n = refresh_kernel_cache(Path(cache_dir), package_dir, kernel_source_digest(package_dir))
    except OSError as exc:
        logger.debug('numba kernel cache %s not refreshed: %s', cache_dir, exc)
        return
    if n:
        logger.info('kernel sources changed: removed %d stale numba cache files', n)

