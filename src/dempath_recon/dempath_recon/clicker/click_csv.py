"""Clicked marker centres and their CSV files: the click record, a session's bounds, the checks.

A click is the centre of one marker in one camera image: ``frame,camera,marker,x,y`` with
``frame`` the frame index of the session, ``camera`` the camera name (``cam_side``,
``cam_front``), ``marker`` the marker number and ``x, y`` the centre in pixels. Pixel convention
(dempath, OpenCV, the detector): integer coordinates at pixel centres, so an image ``w`` pixels
wide spans ``-0.5 <= x <= w - 0.5``.

The paper's Image Clicker (Technologies 13(12) 570, sec. 2.3, Fig. 5) exported one table of
pixel coordinates (X, Y) per tracked particle; :func:`read_particle_csv` reads such per-particle
files (format assumed, the paper does not print it: see the function). The session's store that
saves these files is :mod:`dempath_recon.clicker.clicks`.
"""

from __future__ import annotations

import csv
import io
import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

from dempath_recon.errors import ClickError

CSV_HEADER = ('frame', 'camera', 'marker', 'x', 'y')
Key = tuple[int, str, int]  # (frame, camera, marker)
CAMERA_WORDS = {'side': 'cam_side', 'cam1': 'cam_side', 'front': 'cam_front', 'cam2': 'cam_front'}


class Click(NamedTuple):
    """One marker centre: frame index, camera name, marker number, x and y [px]."""

    frame: int
    camera: str
    marker: int
    x: float
    y: float

    @property
    def key(self) -> Key:
        """(frame, camera, marker): a store holds one point per key."""
        return (self.frame, self.camera, self.marker)


@dataclass(frozen=True)
class ClickBounds:
    """What a session accepts: its frames, cameras with their image sizes, marker numbers.

    Attributes:
        n_frames: Frame indices are 0 .. n_frames - 1.
        sizes: Image (width, height) [px] per camera name.
        markers: The marker numbers of the scene (the paper's grid: 1..15).
    """

    n_frames: int
    sizes: Mapping[str, tuple[int, int]]
    markers: frozenset[int]

    def problem(self, click: Click) -> str | None:
        """What is wrong with ``click`` for this session, or None."""
        if not 0 <= click.frame < self.n_frames:
            return f'frame {click.frame} is not in 0..{self.n_frames - 1}'
        if click.camera not in self.sizes:
            return f'camera {click.camera!r} is not one of {", ".join(self.sizes)}'
        if click.marker not in self.markers:
            return f'marker {click.marker} is not one of the markers {describe(self.markers)}'
        width, height = self.sizes[click.camera]
        if not (-0.5 <= click.x <= width - 0.5 and -0.5 <= click.y <= height - 0.5):
            return (f'point ({click.x:g}, {click.y:g}) px is outside the {width}x{height} '
                    f'image of {click.camera}')
        return None


def describe(markers: Iterable[int]) -> str:
    """``1-15`` for a run of numbers, else the comma-separated list."""
    ordered = sorted(markers)
    if ordered and ordered == list(range(ordered[0], ordered[-1] + 1)) and len(ordered) > 2:
        return f'{ordered[0]}-{ordered[-1]}'
    return ','.join(str(m) for m in ordered)


def parse_markers(text: str) -> frozenset[int]:
    """``'1-15'`` or ``'1,2,7'`` (or both mixed) -> the set of marker numbers.

    Raises:
        ValueError: The text is not such a list.
    """
    numbers: set[int] = set()
    for part in text.split(','):
        match = re.fullmatch(r'\s*(\d+)\s*(?:-\s*(\d+)\s*)?', part)
        if not match:
            msg = f'markers: expected e.g. 1-15 or 1,2,7, got {text!r}'
            raise ValueError(msg)
        first, last = int(match[1]), int(match[2] or match[1])
        numbers.update(range(first, last + 1))
    return frozenset(numbers)


def clicks_to_csv(clicks: Iterable[Click]) -> str:
    """The CSV text ``frame,camera,marker,x,y`` of ``clicks`` in (frame, camera, marker) order."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator='\n')
    writer.writerow(CSV_HEADER)
    for c in sorted(clicks, key=lambda c: c.key):
        writer.writerow([c.frame, c.camera, c.marker, f'{c.x:.3f}', f'{c.y:.3f}'])
    return out.getvalue()


def _row_click(row: Mapping[str, str], name: str, line: int) -> Click:
    try:
        return Click(int(row['frame']), row['camera'].strip(), int(row['marker']),
                     float(row['x']), float(row['y']))
    except (TypeError, ValueError, AttributeError) as err:
        msg = f'{name}: line {line}: not a click row frame,camera,marker,x,y ({err})'
        raise ClickError(msg) from err


def check_clicks(clicks: Sequence[tuple[int, Click]], bounds: ClickBounds, name: str) -> None:
    """Raise on the first (line, click) that the session cannot hold.

    Raises:
        ClickError: ``<name>: line N: <problem>``.
    """
    for line, click in clicks:
        problem = bounds.problem(click)
        if problem:
            msg = f'{name}: line {line}: {problem}'
            raise ClickError(msg)


def read_clicks_text(text: str, bounds: ClickBounds, name: str) -> list[Click]:
    """Parse and check a click CSV (or a paper per-particle CSV, recognised by its header).

    Nothing is accepted unless every row is valid: a file with an unknown marker or a point
    outside its image is refused whole, with the first bad line named.

    Raises:
        ClickError: One line naming the file, the line and the problem.
    """
    rows = list(csv.reader(io.StringIO(text)))
    header = [h.strip().lower() for h in rows[0]] if rows else []
    if not set(CSV_HEADER) <= set(header):
        return read_particle_csv(text, bounds, name)
    index = {h: i for i, h in enumerate(header)}
    numbered = []
    for line, row in enumerate(rows[1:], start=2):
        if not any(cell.strip() for cell in row):
            continue
        record = {h: row[i] if i < len(row) else '' for h, i in index.items()}
        numbered.append((line, _row_click(record, name, line)))
    check_clicks(numbered, bounds, name)
    return [c for _, c in numbered]


def _particle_marker(name: str) -> int:
    numbers = re.findall(r'\d+', Path(name).stem.replace('cam1', '').replace('cam2', ''))
    if not numbers:
        msg = (f'{name}: no marker number in the file name (a per-particle CSV is named after '
               'its particle, e.g. particle_7_side.csv)')
        raise ClickError(msg)
    return int(numbers[-1])


def _particle_camera(name: str) -> str | None:
    words = re.split(r'[^a-z0-9]+', Path(name).stem.lower())
    found = [CAMERA_WORDS[w] for w in words if w in CAMERA_WORDS]
    return found[0] if found else None


def read_particle_csv(text: str, bounds: ClickBounds, name: str) -> list[Click]:
    """Clicks from one of the paper's per-particle CSVs.

    The paper says only that its clicker wrote the pixel coordinates (X, Y) of one selected
    particle per frame to a table exported as CSV, and that the network took the side camera's
    (xs, ys) and the front camera's (xf, yf). Assumed here: one file per particle whose name
    ends with the marker number (``particle_7.csv``, ``p07_side.csv``); a header row; columns
    ``X,Y`` (one camera, named in the file name: side/cam1 or front/cam2) or ``xs,ys,xf,yf``
    (both cameras); an optional ``frame`` (or ``image``, whose last number is taken) column,
    otherwise row k is frame k. Empty cells are frames where the particle was not clicked.

    Raises:
        ClickError: The header matches neither form, or a row is not numbers.
    """
    rows = list(csv.reader(io.StringIO(text)))
    header = [h.strip().lower() for h in rows[0]] if rows else []
    marker = _particle_marker(name)
    if {'xs', 'ys', 'xf', 'yf'} <= set(header):
        columns = {'cam_side': ('xs', 'ys'), 'cam_front': ('xf', 'yf')}
    elif {'x', 'y'} <= set(header):
        camera = _particle_camera(name) or (next(iter(bounds.sizes)) if len(bounds.sizes) == 1
                                            else None)
        if camera is None:
            msg = (f'{name}: a per-particle CSV with X,Y names its camera in the file name '
                   '(side/cam1 or front/cam2)')
            raise ClickError(msg)
        columns = {camera: ('x', 'y')}
    else:
        msg = (f'{name}: header {",".join(header) or "(empty)"!r} is neither '
               'frame,camera,marker,x,y nor a per-particle X,Y or xs,ys,xf,yf table')
        raise ClickError(msg)
    index = {h: i for i, h in enumerate(header)}
    frame_col = next((index[h] for h in ('frame', 'image', 'file') if h in index), None)
    numbered = []
    for line, row in enumerate(rows[1:], start=2):
        cells = [c.strip() for c in row] + [''] * len(header)
        try:
            frame = line - 2 if frame_col is None else int(re.findall(r'\d+',
                                                                      cells[frame_col])[-1])
            for camera, (cx, cy) in columns.items():
                if cells[index[cx]] and cells[index[cy]]:
                    click = Click(frame, camera, marker, float(cells[index[cx]]),
                                  float(cells[index[cy]]))
                    numbered.append((line, click))
        except (ValueError, IndexError) as err:
            msg = f'{name}: line {line}: not a row of numbers ({err})'
            raise ClickError(msg) from err
    check_clicks(numbered, bounds, name)
    return [c for _, c in numbered]
