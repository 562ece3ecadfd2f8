"""Installing LIGGGHTS once: a process that finds it missing while another installs it waits
for the install lock and looks again instead of running apt-get beside it."""

from __future__ import annotations

import os
import stat
import threading
import time
from pathlib import Path

import pytest

from dempath.aptinstall import apt_lock
from dempath_sim.liggghts import install
from dempath_sim.liggghts.errors import LiggghtsNotFoundError


def test_second_process_waits_for_the_install(tmp_path: Path,
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    """While another holder of the install lock puts the binary in place, ensure_liggghts waits
    and returns it without installing a second time (two test workers used to run apt-get at
    once and the second failed on the dpkg lock, skipping 17 tests)."""
    monkeypatch.setenv('DEMPATH_APT_LOCK', str(tmp_path / 'apt.lock'))
    monkeypatch.setenv('PATH', f'{tmp_path}{os.pathsep}{os.environ["PATH"]}')
    monkeypatch.delenv('DEMPATH_LIGGGHTS', raising=False)
    monkeypatch.setattr(install, 'BINARY_NAMES', ('liggghts_being_installed',))
    installs: list[str] = []

    def second_install() -> None:
        installs.append('apt-get')
        msg = 'a second apt-get install ran'
        raise LiggghtsNotFoundError(msg)

    monkeypatch.setattr(install, 'install_liggghts', second_install)
    holding = threading.Event()

    def first_worker() -> None:
        with apt_lock():
            holding.set()
            time.sleep(1.0)
            binary = tmp_path / 'liggghts_being_installed'
            binary.write_text('#!/bin/sh\n')
            binary.chmod(binary.stat().st_mode | stat.S_IXUSR)

    worker = threading.Thread(target=first_worker)
    worker.start()
    assert holding.wait(10.0)
    found = install.ensure_liggghts(install=True)
    worker.join()
    assert installs == [] and found.binary == str(tmp_path / 'liggghts_being_installed')


def test_missing_component_fails_unless_listed(monkeypatch: pytest.MonkeyPatch) -> None:
    """A missing expected component fails the test; DEMPATH_TEST_SKIP makes it a listed skip."""
    from dempath.nodes.pytest_plugin import require_component

    monkeypatch.delenv('DEMPATH_TEST_SKIP', raising=False)
    with pytest.raises(pytest.fail.Exception, match='liggghts is expected and missing'):
        require_component('liggghts', 'not on PATH')
    monkeypatch.setenv('DEMPATH_TEST_SKIP', 'chromium, liggghts')
    with pytest.raises(pytest.skip.Exception, match='skipped on purpose'):
        require_component('liggghts', 'not on PATH')
