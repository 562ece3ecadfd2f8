"""Output folders written whole or not at all, and the check readers make before trusting one.

A command stages its files in a hidden folder beside ``--out`` (``.<name>.partial-<pid>``) and
installs them at the end. A new ``--out`` is the staged folder renamed into place (atomic). An
existing one (a rerun into the same folder) first gets the marker :data:`WRITING_MARKER`, loses
its old manifest, receives each staged file by ``os.replace`` and the manifest last, and then
loses the marker. The manifest (``summary.json`` for ``dempath simulate``) lists every file it
vouches for with its size in bytes (:data:`MANIFEST_KEY`).

A run killed at any moment therefore leaves either the old complete folder, nothing, a hidden
staging folder, or a folder with the marker or without a manifest that matches its files; and
:func:`check_output_folder` refuses the last two with one line, so no reader scores a mix of two
runs or a truncated file.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
from collections.abc import Iterator
from pathlib import Path

from dempath.errors import OutputError

WRITING_MARKER = '.dempath-writing'  # present while files are being moved into the folder
MANIFEST_KEY = 'files'  # manifest entry: {file name: size in bytes}


def staging_folder(out: Path) -> Path:
    """The hidden folder beside ``out`` where a run writes before it installs its files."""
    return out.parent / f'.{out.name}.partial-{os.getpid()}'


@contextlib.contextmanager
def staged_output(out: Path, manifest: str) -> Iterator[Path]:
    """Stage a command's outputs and install them whole into ``out`` when the block ends.

    Args:
        out: The output folder (created, or updated in place when it exists).
        manifest: Name of the JSON file (an object) written last; the block must write it into
            the staging folder. Its :data:`MANIFEST_KEY` entry is filled in here.

    Yields:
        The staging folder to write into.

    Raises:
        OutputError: ``out`` exists and is not a folder, or a file cannot be written.
    """
    out = Path(out)
    if out.exists() and not out.is_dir():
        msg = f'{out}: exists and is not a folder'
        raise OutputError(msg)
    stage = staging_folder(out)
    try:
        shutil.rmtree(stage, ignore_errors=True)
        stage.mkdir(parents=True)
    except OSError as err:
        msg = f'{out}: cannot create the output folder ({err.strerror})'
        raise OutputError(msg) from err
    try:
        yield stage
        _write_manifest(stage, manifest)
        _install(stage, out, manifest)
    finally:
        shutil.rmtree(stage, ignore_errors=True)


def _write_manifest(stage: Path, manifest: str) -> None:
    """Add the size of every staged file to the manifest object."""
    path = stage / manifest
    try:
        record = json.loads(path.read_text(encoding='utf-8'))
    except (OSError, ValueError) as err:
        msg = f'{path}: the run wrote no readable manifest ({err})'
        raise OutputError(msg) from err
    record[MANIFEST_KEY] = {p.name: p.stat().st_size for p in sorted(stage.iterdir())
                            if p.is_file() and p.name != manifest}
    path.write_text(json.dumps(record, indent=2), encoding='utf-8')


def _install(stage: Path, out: Path, manifest: str) -> None:
    """Move the staged files into ``out``: one rename when ``out`` is new, else file by file
    under the writing marker with the manifest last."""
    try:
        if not out.exists():
            stage.rename(out)
            return
        marker = out / WRITING_MARKER
        marker.write_text(f'{os.getpid()}\n', encoding='utf-8')
        (out / manifest).unlink(missing_ok=True)
        for path in sorted(stage.iterdir()):
            if path.name == manifest:
                continue
            if path.is_dir():  # a sub-folder replaces the old one whole
                shutil.rmtree(out / path.name, ignore_errors=True)
            os.replace(path, out / path.name)
        os.replace(stage / manifest, out / manifest)
        marker.unlink()
    except OSError as err:
        msg = f'{out}: cannot install the outputs ({err.strerror})'
        raise OutputError(msg) from err


def check_output_folder(folder: Path, manifest: str) -> None:
    """Refuse a folder that a killed run left half-written.

    A folder is refused when it holds :data:`WRITING_MARKER`, or when its manifest lists files
    that are missing or whose size differs (a file of another run, or one cut short). A folder
    without a manifest, or a manifest without a file list (older outputs), is accepted as is.

    Raises:
        OutputError: One line naming the folder (and file) and what is wrong.
    """
    folder = Path(folder)
    if (folder / WRITING_MARKER).exists():
        msg = (f'{folder}: incomplete outputs (a run was stopped while writing them, '
               f'{WRITING_MARKER} is still there); run the command again')
        raise OutputError(msg)
    try:
        record = json.loads((folder / manifest).read_text(encoding='utf-8'))
    except (OSError, ValueError):
        return
    files = record.get(MANIFEST_KEY) if isinstance(record, dict) else None
    if not isinstance(files, dict):
        return
    for name, size in files.items():
        path = folder / str(name)
        actual = path.stat().st_size if path.is_file() else None
        if actual != size:
            found = 'is missing' if actual is None else f'has {actual} bytes'
            msg = (f'{path}: {found} but {manifest} lists {size} bytes (written by another run '
                   'or cut short); run the command again')
            raise OutputError(msg)


__all__ = ['MANIFEST_KEY', 'WRITING_MARKER', 'check_output_folder', 'staged_output',
           'staging_folder']
