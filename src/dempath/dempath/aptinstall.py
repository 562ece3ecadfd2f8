"""Install Debian packages that tests and backends need (LIGGGHTS, Chromium) through apt-get.

Only when the process runs as root with apt-get on PATH (as on dempath's machines and CI);
otherwise callers raise their own "not installed" error naming the command a user has to run.
Installs run one at a time: :func:`apt_lock` is an exclusive file lock that callers hold while
they look for a component and install it (parallel test workers used to run apt-get at once and
the second failed on the dpkg lock), and apt-get itself waits for dpkg's lock
(``DPkg::Lock::Timeout``) rather than failing when another program holds it.
"""

from __future__ import annotations

import contextlib
import fcntl
import logging
import os
import shutil
import subprocess
import tempfile
from collections.abc import Iterator, Sequence
from pathlib import Path

LOG = logging.getLogger(__name__)
LOCK_NAME = 'dempath-apt.lock'  # in the temporary folder, shared by every dempath process
DPKG_WAIT_S = 600  # how long apt-get waits for another program's dpkg lock


def lock_path() -> Path:
    """The file every dempath process locks around a look-up-and-install."""
    return Path(os.environ.get('DEMPATH_APT_LOCK', Path(tempfile.gettempdir()) / LOCK_NAME))


@contextlib.contextmanager
def apt_lock() -> Iterator[None]:
    """Hold the exclusive install lock (blocks until other dempath processes release it)."""
    with lock_path().open('a') as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def can_install() -> bool:
    """Whether this process may install Debian packages (root with apt-get available)."""
    return hasattr(os, 'geteuid') and os.geteuid() == 0 and shutil.which('apt-get') is not None


def apt_install(packages: Sequence[str], timeout_s: float = 900.0) -> str | None:
    """``apt-get update`` then ``apt-get install`` the packages; the failure, or None if fine.

    Returns:
        None on success, else one line: the command that failed, its status and last output line.
    """
    env = {**os.environ, 'DEBIAN_FRONTEND': 'noninteractive'}
    wait = ['-o', f'DPkg::Lock::Timeout={DPKG_WAIT_S}']
    for cmd in (['apt-get', *wait, 'update', '-q'],
                ['apt-get', *wait, 'install', '-y', '-q', '--no-install-recommends', *packages]):
        LOG.info('running %s', ' '.join(cmd))
        done = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=timeout_s,
                              check=False)
        if done.returncode != 0:
            tail = (done.stderr or done.stdout).strip().splitlines()[-1:] or ['no output']
            return f'{" ".join(cmd)!r} failed ({done.returncode}): {tail[0]}'
    return None
