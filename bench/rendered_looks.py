"""Rendered looks for ``detect_track.py``: named ``dempath twin render`` runs listed in a spec
file, rendered once into a cache and reused.

Image-level variations of one render (``detect_track_variations.py``) keep its packing, its
marker paths and its views; independent packings, tool speeds and cohesion need renders of
their own. A spec (``bench/looks/*.txt``) lists one look a line, its name and then the
arguments of ``dempath twin render tiny_long`` after ``--out`` (``#`` starts a comment);
:func:`rendered_bags` renders the looks not yet in the cache (about a minute each on two
cores; a finished look is marked with ``.done``, so an interrupted run resumes) and gives the
bags in the spec's order. Which spec is held out is the bench's command line: ``--looks`` (held
out, scored to report) or ``--looks-tuning`` (what changes were tuned on).
"""

from __future__ import annotations

import shlex
import shutil
import subprocess
import sys
from pathlib import Path
from typing import NamedTuple

SCENE = 'tiny_long'  # the twin's scene every look renders (a 0.5 s pass of a 3 x 5 grid)
CACHE = Path.home() / '.cache' / 'dempath' / 'bench_looks'  # default cache root


class Look(NamedTuple):
    """One rendered look: its name and its ``dempath twin render`` arguments."""

    name: str
    args: tuple[str, ...]


def read_spec(path: Path) -> list[Look]:
    """The looks of a spec file, in order.

    Raises:
        ValueError: a line without arguments, a name used twice, or an argument the bench
            sets itself (``--out``), each naming the file and line.
    """
    looks: list[Look] = []
    for number, raw in enumerate(path.read_text().splitlines(), 1):
        line = raw.split('#', 1)[0].strip()
        if not line:
            continue
        name, *args = shlex.split(line)
        where = f'{path}:{number}'
        if not args:
            raise ValueError(f'{where}: look {name!r} has no render arguments')
        if '--out' in args:
            raise ValueError(f'{where}: look {name!r} sets --out (the bench places each look)')
        if any(look.name == name for look in looks):
            raise ValueError(f'{where}: look {name!r} is listed twice')
        looks.append(Look(name, tuple(args)))
    if not looks:
        raise ValueError(f'{path}: no look listed')
    return looks


def rendered_bags(spec: Path, cache: Path = CACHE) -> list[Path]:
    """The bags of ``spec``'s looks under ``cache / spec's stem``, rendering the missing ones
    (progress on stderr); a failed render raises ``subprocess.CalledProcessError`` and leaves
    the looks before it in place."""
    looks = read_spec(spec)
    folder = cache / spec.stem
    folder.mkdir(parents=True, exist_ok=True)
    dempath = Path(sys.executable).with_name('dempath')
    bags = []
    for i, look in enumerate(looks, 1):
        bag = folder / look.name
        if not (bag / '.done').exists():
            shutil.rmtree(bag, ignore_errors=True)  # an interrupted render's remains
            print(f'rendering look {i}/{len(looks)} {look.name} ({" ".join(look.args)})',
                  file=sys.stderr, flush=True)
            subprocess.run([str(dempath), 'twin', 'render', SCENE, '--out', str(bag),
                            *look.args], check=True, stdout=sys.stderr)
            (bag / '.done').touch()
        bags.append(bag)
    return bags
