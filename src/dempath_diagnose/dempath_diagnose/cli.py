"""``dempath diagnose``: where the model fails against a measured pass, and what it misses.

``dempath diagnose --measured M --scene S [--force F] [--origin X,Y,Z] --out DIR
[--scheduler ADDR]``. Bad input gives one ``error: <input>: <problem>`` line and exit code 1;
faults of single markers are warned about and the rest is still diagnosed. The command parses
its options into a :class:`~dempath_diagnose.entry.requests.DiagnoseRequest`, calls
:func:`~dempath_diagnose.entry.diagnosis.run_diagnosis` and prints the ranking.
"""

from __future__ import annotations

import sys

from dempath.errors import DempathError
from dempath_diagnose.cli_options import diagnose_parser, diagnose_request
from dempath_diagnose.entry.diagnosis import run_diagnosis
from dempath_diagnose.entry.library_build import library_notice
from dempath_diagnose.entry.requests import DEFAULT_BUDGET

__all__ = ['diagnose_main', 'library_notice']


def diagnose_main(argv: list[str] | None = None) -> int:
    """``dempath diagnose``: where the model fails against a measured pass, what it misses.

    Returns 0, or 1 after one ``error: <input>: <problem>`` line on bad input.
    """
    parser = diagnose_parser('dempath diagnose', __doc__.split('\n')[0])
    parser.add_argument('--budget', dest='extra_budget', type=int, default=None,
                        help='simulations allowed beyond the library where they would settle '
                             f'an open answer (0: none; default {DEFAULT_BUDGET}, or 0 with '
                             '--library)')
    args = parser.parse_args(argv)
    if args.extra_budget is None:  # a library given by path is fixed unless asked otherwise
        args.extra_budget = 0 if args.library is not None else DEFAULT_BUDGET
    try:
        outcome = run_diagnosis(diagnose_request(args, args.extra_budget))
    except (DempathError, ValueError) as err:
        print(f'error: {err}', file=sys.stderr)
        return 1
    from dempath_diagnose.report.diagnosis_outputs import print_ranking

    print_ranking(outcome.data)
    return 0
