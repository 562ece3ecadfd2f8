"""Make ``bags/demo_two_cams``: a small synthetic two-camera recording of 15 moving markers.

SYNTHETIC DATA, made by ``dempath_twin.field.two_cams.write_two_cams_bag`` (what it holds: that
module's docstring). Usage: ``.venv/bin/python bags/make_demo_bag.py [OUT_DIR]``.
"""

from __future__ import annotations

import sys
from pathlib import Path

from dempath_twin.field.two_cams import write_two_cams_bag


def main(argv: list[str]) -> int:
    """Write the bag (default beside this script) and print its size."""
    out = write_two_cams_bag(Path(argv[0]) if argv else Path(__file__).resolve().parent
                             / 'demo_two_cams')
    print(f'{out}: {sum(p.stat().st_size for p in out.iterdir()) / 1e6:.2f} MB')
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
