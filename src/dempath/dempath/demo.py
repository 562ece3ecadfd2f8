"""``dempath demo``: the main job, as a list of named steps run in order.

Today it replays the demo bag from ``bags/`` through player -> recorder in one process (no
launch) into ``out/demo/`` and prints what was recorded. The later steps of the pipeline
(calibration, reconstruction, simulation, comparison) are listed with ``run=None`` and reported
as not there yet; a package adds its step by giving it a ``run`` function.
"""

from __future__ import annotations

import argparse
import shutil
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from dempath.bagio import open_bag
from dempath.errors import DempathError

REPO = Path(__file__).resolve().parents[3]
DEMO_BAG = REPO / 'bags' / 'demo_two_cams'
DEMO_OUT = REPO / 'out' / 'demo'


@dataclass
class DemoContext:
    """What the steps share: inputs, the output folder and each step's results by name."""

    bag: Path
    out: Path
    rate: float
    results: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class Step:
    """One named step of the demo; ``run`` returns a printable summary (None: not there yet)."""

    name: str
    what: str
    run: Callable[[DemoContext], str] | None = None


def replay_and_record_step(ctx: DemoContext) -> str:
    """Play every topic of the demo bag into a recorder writing ``out/recorded``."""
    from dempath.nodes.pipeline import replay_and_record

    with open_bag(ctx.bag) as bag:
        topics = [t.name for t in bag.select()]
    output = ctx.out / 'recorded'
    if output.exists():
        shutil.rmtree(output)
    result = replay_and_record(ctx.bag, output, topics, rate=ctx.rate, quiet=True)
    ctx.results['recorded'] = output
    if not result.complete:
        msg = f'{output}: recording incomplete:\n{result.summary}'
        raise DempathError(msg)
    return f'{output}: {result.wall_s:.1f} s wall\n{result.summary}'


STEPS: list[Step] = [
    Step('replay+record', 'play bags/demo_two_cams through player -> recorder into MCAP',
         replay_and_record_step),
    Step('calibration', 'ChArUco calibration of the two cameras (dempath_calib)'),
    Step('reconstruction', 'pixel points -> 3D marker trajectories (dempath_recon)'),
    Step('simulation', 'DEM run of the tillage tool in sand (dempath_sim)'),
    Step('comparison', 'DTW / nRMSE comparison of measured and simulated trajectories '
         '(dempath_compare)'),
]


def demo_main(argv: list[str]) -> int:
    """``dempath demo``: run the steps of the main job that exist and name the missing ones."""
    parser = argparse.ArgumentParser(prog='dempath demo', description=demo_main.__doc__)
    parser.add_argument('--bag', type=Path, default=DEMO_BAG, help='input bag')
    parser.add_argument('--out', type=Path, default=DEMO_OUT, help='output folder')
    parser.add_argument('--rate', type=float, default=1.0, help='playback speed factor')
    args = parser.parse_args(argv)
    ctx = DemoContext(args.bag, args.out, args.rate)
    try:
        open_bag(args.bag).close()
        ctx.out.mkdir(parents=True, exist_ok=True)
    except (DempathError, OSError) as err:
        print(f'error: {err}', file=sys.stderr)
        return 1
    missing = []
    for number, step in enumerate(STEPS, 1):
        print(f'[{number}/{len(STEPS)}] {step.name}: {step.what}')
        if step.run is None:
            print('    not there yet')
            missing.append(step.name)
            continue
        try:
            print('    ' + step.run(ctx).replace('\n', '\n    '))
        except DempathError as err:
            print(f'error: {err}', file=sys.stderr)
            return 1
    if missing:
        print(f'not there yet: {", ".join(missing)} (later issues add these steps)')
    return 0
