"""``dempath recalibrate``: switch on the diagnosed effect, fit its strength, watch the error fall.

``dempath recalibrate --measured M --scene S [--force F] [--diagnosis DIR/diagnosis.json |
--effect NAME[=START] ...] [--also PARAM ...] --out DIR [--budget N] [--scheduler ADDR]
[--publish-progress]`` plus every option of ``dempath diagnose`` (the library and the
allowance). Bad input: one ``error: <input>: <problem>`` line and exit code 1; whatever was
computed is written first (a lost scheduler or Ctrl-C still write the best scene so far). The
command parses its options into a
:class:`~dempath_diagnose.entry.requests.RecalibrationRequest`, calls
:func:`~dempath_diagnose.entry.recalibration.run_recalibration` and prints what changed.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from contextlib import ExitStack
from pathlib import Path

from dempath.errors import DempathError
from dempath_diagnose.cli_options import diagnose_parser, diagnose_request
from dempath_diagnose.entry.recalibration import run_recalibration, summary_lines
from dempath_diagnose.entry.requests import RecalibrationRequest
from dempath_diagnose.recalibration.progress import fan_out, printer
from dempath_diagnose.recalibration.targets import parse_effects


def _parser() -> argparse.ArgumentParser:
    p = diagnose_parser('dempath recalibrate', __doc__.split('\n')[0])
    p.add_argument('--diagnosis', type=Path, help='diagnosis.json of an earlier diagnosis')
    p.add_argument('--effect', action='append', default=[],
                   help='NAME or NAME=START: candidate(s) to fit (tried in turn)')
    p.add_argument('--also', action='append', default=[],
                   help='refit this existing parameter beside the effect (CMA-ES; repeatable)')
    p.add_argument('--budget', type=int, default=12, help='at most this many simulations')
    p.add_argument('--seeds-per-eval', type=int, default=2,
                   help='library packing seeds per real evaluation (paired with the baseline)')
    p.add_argument('--publish-progress', action='store_true',
                   help='publish dempath_msgs/RecalibrationProgress on /diagnosis/recalibration')
    return p


def recalibrate_main(argv: Sequence[str] | None = None) -> int:
    """``dempath recalibrate``: fit the missing effect's strength against the measurement.

    Returns 0, or 1 after one ``error: <input>: <problem>`` line.
    A lost scheduler gives its error line after the outputs (best scene so far) are written.
    """
    args = _parser().parse_args(argv)
    try:
        request = RecalibrationRequest(
            diagnose=diagnose_request(args, budget=0), diagnosis_file=args.diagnosis,
            effects=parse_effects(args.effect), also=tuple(args.also), budget=args.budget,
            seeds_per_eval=args.seeds_per_eval)
        with ExitStack() as stack:
            callbacks = [printer()]
            if args.publish_progress:  # the ROS publisher beside the terminal lines
                from dempath_diagnose.nodes.progress_publisher import progress_publisher

                callbacks.append(stack.enter_context(progress_publisher(args.out.name)))
            data = run_recalibration(request, progress=fan_out(callbacks)).data
    except (DempathError, ValueError) as err:
        print(f'error: {err}', file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f'error: interrupted (Ctrl-C) before the fit started; {args.out} holds what was '
              'written', file=sys.stderr)
        return 130
    print('\n'.join(summary_lines(data)))
    if data['stop'] == 'scheduler_lost':
        print(f'error: {data["note"]}', file=sys.stderr)
        return 1
    return 130 if data['stop'] == 'interrupted' else 0
