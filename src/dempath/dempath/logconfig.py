"""Logging of every ``dempath`` command, configured once by the dispatcher.

dempath's own loggers (``dempath``, ``dempath_sim``, ...: the core modules log through
``logging.getLogger(__name__)``) print warnings, so that a command's output stays its result
(and bad input one ``error:`` line); the long commands whose log lines are their progress
(``PROGRESS_COMMANDS``: the MLP's epochs in ``dempath recon-train``, the validation's cases)
print INFO too. Each ``-v`` shows one level more (INFO, then DEBUG); ``-vv`` also shows every
library's debug lines; ``-q`` warnings only. Other libraries print their warnings.
"""

from __future__ import annotations

import logging
import sys
from typing import TextIO

PACKAGES = ('dempath', 'dempath_calib', 'dempath_sim', 'dempath_compare', 'dempath_recon',
            'dempath_twin', 'dempath_diagnose', 'dempath_bringup')
PROGRESS_COMMANDS = frozenset({'recon-train', 'recon-report', 'validate', 'calibrate'})
FORMAT = '%(levelname)s %(name)s: %(message)s'
VERBOSE = {'-v': 1, '--verbose': 1, '-vv': 2}  # anywhere on the command line
QUIET = {'-q', '--quiet'}  # before the command only (``simulate --quiet`` is simulate's own)


def split_verbosity(args: list[str]) -> tuple[int, list[str]]:
    """Take the logging flags off the command line: ``(verbosity, the other arguments)``.

    ``-v``/``--verbose`` may stand before the command or among its arguments (no command defines
    them) and each adds one; ``-q``/``--quiet`` before the command takes one. Arguments after
    ``--`` are the command's.
    """
    verbosity, rest = 0, []
    for k, arg in enumerate(args):
        if arg == '--':
            rest.extend(args[k:])
            break
        if arg in VERBOSE:
            verbosity += VERBOSE[arg]
        elif arg in QUIET and not rest:
            verbosity -= 1
        else:
            rest.append(arg)
    return verbosity, rest


class StderrHandler(logging.StreamHandler):  # type: ignore[type-arg]
    """Writes to whatever ``sys.stderr`` is at the time of the record (tests swap it)."""

    def __init__(self) -> None:
        super().__init__(sys.stderr)
        self.setFormatter(logging.Formatter(FORMAT))

    @property  # type: ignore[override]
    def stream(self) -> TextIO:
        return sys.stderr

    @stream.setter
    def stream(self, _value: TextIO) -> None:
        pass


def configure_logging(verbosity: int = 0, progress: bool = False) -> None:
    """dempath's one stderr handler on the root logger, levels by ``verbosity`` (module doc).

    Args:
        verbosity: the count of ``-v`` less the count of ``-q``.
        progress: the command logs its progress at INFO (one of ``PROGRESS_COMMANDS``).

    Calling it again replaces the handler it installed before (no doubled lines) and leaves any
    other handler (a library's, pytest's) alone.
    """
    root = logging.getLogger()
    for handler in [h for h in root.handlers if isinstance(h, StderrHandler)]:
        root.removeHandler(handler)
    root.addHandler(StderrHandler())
    if verbosity >= 2:
        root.setLevel(logging.DEBUG)
    base = logging.INFO if progress else logging.WARNING
    ours = min(max(base - 10 * verbosity, logging.DEBUG), logging.WARNING)
    for name in PACKAGES:
        logging.getLogger(name).setLevel(ours)
