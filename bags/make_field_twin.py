"""Make ``bags/field_twin_<scene>``: the demo's synthetic field recording (the "measurement").

SYNTHETIC DATA, made by ``dempath_twin.field.demo_bag.make_field_twin`` (what it holds: that
module's docstring and docs/demo.md). This script only picks the default output beside itself; the
same is ``dempath twin field OUT --scene NAME``.

Usage::

    .venv/bin/python bags/make_field_twin.py [--scene tiny] [--sim-dir DIR] [--out DIR]

``--sim-dir`` reuses the output folder of an earlier ``dempath simulate`` run with the hidden
setting (its ``markers.csv`` and ``summary.json``); without it the run is made here (minutes).
"""

from __future__ import annotations

import sys
from pathlib import Path

from dempath_twin.cli import twin_main

HERE = Path(__file__).resolve().parent


def main(argv: list[str]) -> int:
    """``dempath twin field`` with the bag beside this script by default."""
    scene = argv[argv.index('--scene') + 1] if '--scene' in argv else 'tiny'
    if '--out' in argv:
        k = argv.index('--out')
        out, rest = argv[k + 1], argv[:k] + argv[k + 2:]
    else:
        out, rest = str(HERE / f'field_twin_{Path(scene).stem}'), argv
    return twin_main(['field', out, *rest])


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
