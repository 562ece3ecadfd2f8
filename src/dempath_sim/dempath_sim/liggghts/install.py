"""Find LIGGGHTS 3.8 on this machine and install it from Debian packages when allowed.

The Debian package ``liggghts`` (3.8.0) provides ``/usr/bin/liggghts``; it depends on
``mpi-default-bin`` (OpenMPI), which provides ``mpirun``. ``ensure_liggghts`` installs it with
``apt-get`` when the binary is missing and the process runs as root; otherwise it raises
:class:`LiggghtsNotFoundError` with the command a user has to run.
"""

from __future__ import annotations

import logging
import os
import shutil
from dataclasses import dataclass

from dempath.aptinstall import apt_install, apt_lock
from dempath_sim.liggghts.errors import LiggghtsNotFoundError

logger = logging.getLogger(__name__)

# Names of the LIGGGHTS executable: the Debian package and source builds (make auto / fedora).
BINARY_NAMES = ('liggghts', 'lmp_auto', 'lmp_fedora', 'lmp_ubuntu')
APT_PACKAGE = 'liggghts'
INSTALL_HINT = 'sudo apt-get install -y liggghts'


@dataclass(frozen=True)
class LiggghtsInstall:
    """Where LIGGGHTS and mpirun live.

    Attributes:
        binary: Absolute path of the LIGGGHTS executable.
        mpirun: Absolute path of mpirun, or None when only serial runs are possible.
    """

    binary: str
    mpirun: str | None


def find_liggghts(binary: str | None = None) -> LiggghtsInstall | None:
    """Locate the LIGGGHTS executable and mpirun on PATH.

    Args:
        binary: Explicit executable name or path; None tries ``$DEMPATH_LIGGGHTS`` and then
            :data:`BINARY_NAMES`.

    Returns:
        The install, or None if no executable is found.
    """
    names = [binary] if binary else [os.environ.get('DEMPATH_LIGGGHTS', ''), *BINARY_NAMES]
    for name in names:
        path = shutil.which(name) if name else None
        if path:
            return LiggghtsInstall(binary=path, mpirun=shutil.which('mpirun'))
    return None


def can_install() -> bool:
    """Whether this process may install Debian packages (root with apt-get available)."""
    return hasattr(os, 'geteuid') and os.geteuid() == 0 and shutil.which('apt-get') is not None


def install_liggghts(timeout_s: float = 900.0) -> None:
    """Install the Debian package ``liggghts`` (with OpenMPI) through apt-get.

    Raises:
        LiggghtsNotFoundError: Not root, no apt-get, or apt-get failed (names the command).
    """
    if not can_install():
        msg = f'liggghts: not installed and this process cannot install it; run {INSTALL_HINT!r}'
        raise LiggghtsNotFoundError(msg)
    failure = apt_install([APT_PACKAGE], timeout_s)
    if failure:
        msg = f'liggghts: {failure}'
        raise LiggghtsNotFoundError(msg)


def ensure_liggghts(binary: str | None = None, install: bool = True) -> LiggghtsInstall:
    """Return the LIGGGHTS install, installing the Debian package first if allowed.

    Args:
        binary: Explicit executable name or path (see :func:`find_liggghts`).
        install: Try apt-get when LIGGGHTS is missing (needs root).

    Raises:
        LiggghtsNotFoundError: LIGGGHTS is missing and cannot be installed.
    """
    found = find_liggghts(binary)
    if found is None and install and binary is None:
        with apt_lock():  # another process may be installing it right now: wait, look again
            found = find_liggghts()
            if found is None:
                install_liggghts()
                found = find_liggghts()
    if found is None:
        name = binary or 'liggghts'
        msg = f'{name}: LIGGGHTS executable not found on PATH; run {INSTALL_HINT!r}'
        raise LiggghtsNotFoundError(msg)
    return found
