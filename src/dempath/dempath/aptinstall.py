"""Install Debian packages that tests and backends need (LIGGGHTS, Chromium) through apt-get.

Only when the process runs as root with apt-get on PATH (as on dempath's machines and CI);
otherwise callers raise their own "not installed" error naming the command a user has to run.
"""

from __future__ import annotations

import logging
import os
import shutil
import subprocess
from collections.abc import Sequence

LOG = logging.getLogger(__name__)


def can_install() -> bool:
    """Whether this process may install Debian packages (root with apt-get available)."""
    return hasattr(os, 'geteuid') and os.geteuid() == 0 and shutil.which('apt-get') is not None


def apt_install(packages: Sequence[str], timeout_s: float = 900.0) -> str | None:
    """``apt-get update`` then ``apt-get install`` the packages; the failure, or None if fine.

    Returns:
        None on success, else one line: the command that failed, its status and last output line.
    """
    env = {**os.environ, 'DEBIAN_FRONTEND': 'noninteractive'}
    for cmd in (['apt-get', 'update', '-q'],
                ['apt-get', 'install', '-y', '-q', '--no-install-recommends', *packages]):
        LOG.info('running %s', ' '.join(cmd))
        done = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=timeout_s,
                              check=False)
        if done.returncode != 0:
            tail = (done.stderr or done.stdout).strip().splitlines()[-1:] or ['no output']
            return f'{" ".join(cmd)!r} failed ({done.returncode}): {tail[0]}'
    return None
