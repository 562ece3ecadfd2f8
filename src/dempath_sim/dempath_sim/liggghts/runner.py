"""Run a LIGGGHTS input deck (serial or under mpirun) and turn failures into one clear line.

LIGGGHTS writes ``ERROR: ...`` to its screen output and to the log file given with ``-log``;
:func:`run_deck` keeps both in the work directory and, on failure, raises
:class:`LiggghtsRunError` with the first error line and the log's path.
"""

from __future__ import annotations

import logging
import os
import subprocess
import time
from dataclasses import dataclass
from pathlib import Path

from dempath_sim.liggghts.errors import LiggghtsNotFoundError, LiggghtsRunError
from dempath_sim.liggghts.install import LiggghtsInstall, ensure_liggghts

logger = logging.getLogger(__name__)



@dataclass(frozen=True)
class RunOutput:
    """What a finished LIGGGHTS run left behind.

    Attributes:
        workdir: Directory the run wrote its dumps and logs into.
        log_path: The LIGGGHTS log file.
        wall_time_s: Wall-clock duration of the run [s].
        loop_time_s: Sum of the ``Loop time of X`` lines (time spent in ``run``) [s].
        nprocs: Number of MPI processes.
    """

    workdir: Path
    log_path: Path
    wall_time_s: float
    loop_time_s: float
    nprocs: int


def _command(inst: LiggghtsInstall, deck: Path, nprocs: int) -> list[str]:
    base = [inst.binary, '-in', deck.name, '-log', f'log.{deck.name}', '-echo', 'none']
    if nprocs <= 1:
        return base
    if inst.mpirun is None:
        msg = f'mpirun: not found on PATH, needed for a {nprocs}-process LIGGGHTS run'
        raise LiggghtsNotFoundError(msg)
    return [inst.mpirun, '--allow-run-as-root', '--oversubscribe', '-np', str(nprocs), *base]


def first_error(text: str) -> str | None:
    """The first ``ERROR`` line of a LIGGGHTS screen output or log, without its source tag."""
    for line in text.splitlines():
        if line.startswith('ERROR'):
            return line.split(' (', 1)[0].strip() if '.cpp:' in line else line.strip()
    return None


def loop_time(log_text: str) -> float:
    """Total of the ``Loop time of X on N procs`` lines of a LIGGGHTS log [s]."""
    total = 0.0
    for line in log_text.splitlines():
        if line.startswith('Loop time of'):
            total += float(line.split()[3])
    return total


def run_deck(deck: Path, nprocs: int = 1, timeout_s: float = 3600.0,
             install: LiggghtsInstall | None = None) -> RunOutput:
    """Run ``deck`` with LIGGGHTS in the deck's directory.

    Args:
        deck: The input script; relative paths inside it are relative to its directory.
        nprocs: MPI processes (1 = run the binary directly).
        timeout_s: Kill the run after this wall time [s].
        install: The LIGGGHTS install; None = :func:`ensure_liggghts`.

    Returns:
        The run's output description.

    Raises:
        LiggghtsNotFoundError: LIGGGHTS or mpirun is missing.
        LiggghtsRunError: LIGGGHTS failed or timed out (names the deck, the error, the log).
    """
    deck = Path(deck).resolve()
    inst = install or ensure_liggghts()
    cmd = _command(inst, deck, nprocs)
    env = {**os.environ, 'OMP_NUM_THREADS': '1', 'OMPI_MCA_btl_vader_single_copy_mechanism':
           'none', 'OMPI_ALLOW_RUN_AS_ROOT': '1', 'OMPI_ALLOW_RUN_AS_ROOT_CONFIRM': '1'}
    log_path = deck.parent / f'log.{deck.name}'
    screen = deck.parent / f'screen.{deck.name}'
    logger.info('running %s in %s', ' '.join(cmd), deck.parent)
    start = time.perf_counter()
    try:
        with screen.open('w') as out:
            done = subprocess.run(cmd, cwd=deck.parent, stdout=out, stderr=subprocess.STDOUT,
                                  env=env, timeout=timeout_s, check=False)
    except subprocess.TimeoutExpired as err:
        msg = f'liggghts: {deck}: timed out after {timeout_s:.0f} s (log {log_path})'
        raise LiggghtsRunError(msg) from err
    wall = time.perf_counter() - start
    text = screen.read_text(errors='replace')
    log_text = log_path.read_text(errors='replace') if log_path.exists() else ''
    error = first_error(text) or first_error(log_text)
    if done.returncode != 0 or error is not None:
        reason = error or f'exit status {done.returncode}'
        msg = f'liggghts: {deck}: {reason} (log {log_path if log_path.exists() else screen})'
        raise LiggghtsRunError(msg)
    return RunOutput(workdir=deck.parent, log_path=log_path, wall_time_s=wall,
                     loop_time_s=loop_time(log_text), nprocs=nprocs)
