"""The ``dempath`` dispatcher: help from the sources (no command module imported), one line per
command, logging configured once with -v/-q."""

from __future__ import annotations

import json
import logging
import subprocess
import sys

import pytest

from dempath.cli import available_commands, docstring_summary, main
from dempath.logconfig import PACKAGES, StderrHandler, configure_logging, split_verbosity

HELP_IMPORTS = ('import json, sys; from dempath.cli import main; main(["--help"]); '
                'print(json.dumps(sorted(sys.modules)))')


def test_help_imports_no_command_module() -> None:
    """``dempath --help`` reads the summaries with ast: no dempath_* package, numpy or torch."""
    done = subprocess.run([sys.executable, '-c', HELP_IMPORTS], capture_output=True, text=True,
                          check=True)
    modules = json.loads(done.stdout.strip().splitlines()[-1])
    heavy = [m for m in modules if m.split('.')[0] in {'numpy', 'torch', 'numba', 'cv2', 'rclpy',
                                                       'dask', 'scipy'}
             or (m.startswith('dempath_') and '.' in m)]
    assert heavy == [], heavy


def test_every_command_has_a_one_line_summary(capsys: pytest.CaptureFixture[str]) -> None:
    """Each command's line says what it does (not 'Entry point of ...'), on one line."""
    assert main(['--help']) == 0
    out = capsys.readouterr().out
    commands = available_commands()
    for name, target in commands.items():
        summary = docstring_summary(target)
        assert summary, f'{name}: {target} has no docstring'
        assert not summary.startswith(('Entry point', '``')), f'{name}: {summary}'
        assert len(f'  {name:<12} {summary}') <= 99, f'{name}: summary too long: {summary}'
        assert f'  {name:<12} {summary}' in out


def test_verbosity_flags_are_taken_off_the_command_line() -> None:
    """-v anywhere, -q only before the command, nothing after --."""
    assert split_verbosity(['-v', 'simulate', 'tiny']) == (1, ['simulate', 'tiny'])
    assert split_verbosity(['simulate', 'tiny', '--verbose']) == (1, ['simulate', 'tiny'])
    assert split_verbosity(['-vv', 'demo']) == (2, ['demo'])
    assert split_verbosity(['-q', 'simulate', '--quiet']) == (-1, ['simulate', '--quiet'])
    assert split_verbosity(['play', '--', '-v']) == (0, ['play', '--', '-v'])


def test_logging_levels_and_one_handler(capsys: pytest.CaptureFixture[str]) -> None:
    """Warnings by default, INFO for a progress command or with -v, DEBUG with -v on a progress
    command, warnings with -q; one handler however often it is configured."""
    root = logging.getLogger()
    try:
        configure_logging(0)
        logging.getLogger('dempath_sim.fill').info('hidden')
        logging.getLogger('dempath_sim.fill').warning('shown')
        assert capsys.readouterr().err == 'WARNING dempath_sim.fill: shown\n'
        configure_logging(0, progress=True)
        configure_logging(0, progress=True)
        assert sum(isinstance(h, StderrHandler) for h in root.handlers) == 1
        logging.getLogger('dempath_recon.methods.nets').info('epoch 1/12')
        logging.getLogger('dempath_sim.fill').debug('hidden')
        assert capsys.readouterr().err == 'INFO dempath_recon.methods.nets: epoch 1/12\n'
        configure_logging(1)
        logging.getLogger('dempath_sim.fill').info('shown')
        logging.getLogger('dempath_sim.fill').debug('hidden')
        assert capsys.readouterr().err == 'INFO dempath_sim.fill: shown\n'
        configure_logging(1, progress=True)
        logging.getLogger('dempath_sim.fill').debug('shown')
        assert capsys.readouterr().err == 'DEBUG dempath_sim.fill: shown\n'
        configure_logging(-1, progress=True)
        logging.getLogger('dempath_recon.methods.nets').info('hidden')
        assert capsys.readouterr().err == ''
    finally:
        for handler in [h for h in root.handlers if isinstance(h, StderrHandler)]:
            root.removeHandler(handler)
        for name in PACKAGES:
            logging.getLogger(name).setLevel(logging.NOTSET)
