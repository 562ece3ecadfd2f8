"""The click store of a clicker session: one point per (frame, camera, marker), saved safely.

The store keeps one point per (frame, camera, marker), an undo history of whole actions (a
click, a deletion, an import, an acceptance of detections), and writes its CSV file
(:mod:`dempath_recon.clicker.click_csv`) atomically (temporary file in the same folder, fsync,
``os.replace``) after every change, so a closed browser or a killed server loses no click
already saved. One session at a time holds a click file (a lock beside it).
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import tempfile
import threading
from collections.abc import Iterator, Sequence
from pathlib import Path

from dempath_recon.clicker.click_csv import (
    Click,
    ClickBounds,
    Key,
    clicks_to_csv,
    read_clicks_text,
)
from dempath_recon.errors import ClickError


@contextlib.contextmanager
def click_file_lock(path: Path) -> Iterator[None]:
    """Hold the click file for one session: a second session on the same file would save over
    the first one's clicks (the last writer wins), so it is refused instead.

    The lock is ``fcntl.flock`` on ``.<name>.lock`` beside the file (released when the process
    ends, also when it is killed).

    Raises:
        ClickError: Another session holds the file (names its process), or no lock file can be
            made in the folder.
    """
    lock = path.with_name(f'.{path.name}.lock')
    try:
        handle = lock.open('a+', encoding='utf-8')
    except OSError as err:
        msg = f'{path}: cannot lock the click file ({err.strerror or err})'
        raise ClickError(msg) from err
    with handle:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            handle.seek(0)
            owner = handle.read().strip() or 'another process'
            msg = (f'{path}: another dempath click session ({owner}) is using this click file; '
                   'stop it first or give another --out')
            raise ClickError(msg) from None
        handle.seek(0)
        handle.truncate()
        handle.write(f'pid {os.getpid()}\n')
        handle.flush()
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def atomic_write_text(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` so that a reader sees the old or the new file, never half.

    Raises:
        ClickError: The folder cannot be written.
    """
    try:
        fd, tmp = tempfile.mkstemp(prefix=f'.{path.name}.', suffix='.tmp', dir=path.parent)
        with os.fdopen(fd, 'w', newline='') as handle:
            handle.write(text)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, path)
    except OSError as err:
        msg = f'{path}: cannot save the clicks ({err.strerror or err})'
        raise ClickError(msg) from err


class ClickStore:
    """The clicks of one session, saved to its own CSV file after every change.

    Thread-safe (the web server answers requests in threads). The history holds whole actions,
    each a list of (key, previous point or None), so that :meth:`undo` reverts an import or an
    acceptance of detections in one step, as it reverts a click.

    Args:
        path: The session's click file (the only file the page can change).
        bounds: What the session accepts.
    """

    def __init__(self, path: Path, bounds: ClickBounds) -> None:
        self.path = path
        self.bounds = bounds
        self.points: dict[Key, tuple[float, float]] = {}
        self.history: list[list[tuple[Key, tuple[float, float] | None]]] = []
        self.lock = threading.Lock()

    def load(self) -> int:
        """Resume from the click file if it exists; return how many clicks it held.

        Raises:
            ClickError: The file is unreadable or holds a click this session cannot take.
        """
        if not self.path.exists():
            return 0
        try:
            text = self.path.read_text()
        except (OSError, UnicodeDecodeError) as err:
            msg = f'{self.path}: cannot read the click file ({err})'
            raise ClickError(msg) from err
        clicks = read_clicks_text(text, self.bounds, str(self.path))
        with self.lock:
            self.points = {c.key: (c.x, c.y) for c in clicks}
        return len(clicks)

    def apply(self, changes: Sequence[tuple[Key, tuple[float, float] | None]]) -> None:
        """Set (or delete, for None) points as one undoable action, then save."""
        with self.lock:
            action = [(key, self.points.get(key)) for key, _ in changes]
            for key, point in changes:
                self._put(key, point)
            if action:
                self.history.append(action)
            self._save()

    def set(self, click: Click) -> None:
        """Place (or move) one marker's centre.

        Raises:
            ClickError: The click is outside the session (frame, camera, marker or image).
        """
        problem = self.bounds.problem(click)
        if problem:
            raise ClickError(f'click: {problem}')
        self.apply([(click.key, (click.x, click.y))])

    def undo(self) -> bool:
        """Revert the last action; False when there is none."""
        with self.lock:
            if not self.history:
                return False
            for key, point in reversed(self.history.pop()):
                self._put(key, point)
            self._save()
            return True

    def clicks(self, frame: int | None = None) -> list[Click]:
        """Every click (or those of one frame), in key order."""
        with self.lock:
            items = sorted(self.points.items())
        return [Click(*key, *xy) for key, xy in items if frame is None or key[0] == frame]

    def _put(self, key: Key, point: tuple[float, float] | None) -> None:
        if point is None:
            self.points.pop(key, None)
        else:
            self.points[key] = point

    def _save(self) -> None:
        atomic_write_text(self.path, clicks_to_csv(Click(*k, *xy) for k, xy in
                                                   self.points.items()))
