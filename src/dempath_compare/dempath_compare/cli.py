"""``dempath compare MEASURED MODEL --out DIR``: the paper's comparison from the command line."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import NoReturn

from dempath.errors import DempathError
from dempath_compare.config import CompareConfig, Matching, Pairing, RangeKind, RankBy
from dempath_compare.scoring import CompareResult


class OneLineParser(argparse.ArgumentParser):
    """An argument parser whose usage errors are one ``error: ...`` line (exit code 2)."""

    def error(self, message: str) -> NoReturn:
        """Print one line and exit 2."""
        self.exit(2, f'error: {self.prog}: {message}\n')


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``dempath compare``."""
    parser = OneLineParser(
        prog='dempath compare',
        description='Score model particle trajectories against measured marker trajectories '
                    '(start of motion, DTW, nearest-point distances, MAE, RMSE, nRMSE, ranking).')
    parser.add_argument('measured', help='measured trajectories: CSV file, folder or bag')
    parser.add_argument('model', help='model trajectories: CSV file, folder or bag')
    parser.add_argument('--out', required=True, help='output folder')
    parser.add_argument('--top', type=int, default=10, help='N best kept per experiment [10]')
    parser.add_argument('--sp', type=float, default=3.0, help='start-of-motion sensitivity [3]')
    parser.add_argument('--z-weight', type=float, default=1.0, help='Z weight w of d_i [1]')
    parser.add_argument('--rank-by', choices=[r.value for r in RankBy], default='sum')
    parser.add_argument('--matching', choices=[m.value for m in Matching], default='dtw')
    parser.add_argument('--pairing', choices=[p.value for p in Pairing], default='auto')
    parser.add_argument('--range', dest='range_kind', choices=[r.value for r in RangeKind],
                        default='extent', help='nRMSE normaliser [extent]')
    parser.add_argument('--trim-y-drop', type=float, default=None,
                        help='trim measured ends once Y falls this far below its max [m]')
    parser.add_argument('--rest-samples', type=int, default=5, help='rest-phase samples [5]')
    parser.add_argument('--dtw-engine', choices=['kernel', 'dtaidistance'], default='kernel',
                        help='source of the DTW distances (identical numbers) [kernel]')
    parser.add_argument('--identity-from-names', action='store_true',
                        help='tool speed and seed from names (experiment_1p5ms, '
                             '<scene>-s<seed>-<hash>) where no run metadata say them')
    parser.add_argument('--no-plots', action='store_true', help='skip the PNG figures')
    parser.add_argument('--model-map', type=Path, metavar='YAML',
                        help='how to read a foreign model export: a LIGGGHTS dump (its time '
                             'step) or an EDEM/Rocky CSV (columns, units, axes); see '
                             'docs/compare.md')
    return parser


def print_ranking(result: CompareResult, top: int) -> None:
    """The N best model trajectories per experiment as rich tables on stdout."""
    from rich.console import Console
    from rich.table import Table

    console = Console()
    s, meas, mod = result.scores, result.measured, result.model
    for e, label in enumerate(meas.labels):
        if meas.problems[e]:
            console.print(f'[yellow]{label}: not scored: {meas.problems[e]}[/]')
            continue
        table = Table(title=f'{label} (range {s.ranges[e] * 1e3:.1f} mm)')
        for name in ('rank', 'model', 'S_sum [m]', 'MAE [mm]', 'RMSE [mm]', 'nRMSE [%]',
                     'DTW [m]'):
            table.add_column(name, justify='right')
        for j in result.best(e, top):
            table.add_row(str(s.rank[e, j]), mod.labels[j], f'{s.s_sum[e, j]:.4f}',
                          f'{s.s_mean[e, j] * 1e3:.2f}', f'{s.rmse[e, j] * 1e3:.2f}',
                          f'{s.nrmse[e, j]:.2f}', f'{s.dtw[e, j]:.4f}')
        console.print(table)


def compare_main(argv: list[str]) -> int:
    """``dempath compare MEASURED MODEL --out DIR``: score model against measured trajectories."""
    from dempath_compare.comparison_folder import write_outputs
    from dempath_compare.foreign import load_mapping
    from dempath_compare.pipeline import compare_paths, problems

    args = build_parser().parse_args(argv)
    try:
        config = CompareConfig(top_n=args.top, sp=args.sp, z_weight=args.z_weight,
                               rank_by=args.rank_by, matching=args.matching,
                               pairing=args.pairing, range_kind=args.range_kind,
                               trim_y_drop=args.trim_y_drop, rest_samples=args.rest_samples,
                               dtw_engine=args.dtw_engine,
                               identity_from_names=args.identity_from_names)
        model_map = load_mapping(args.model_map) if args.model_map else None
        result = compare_paths(args.measured, args.model, config, model_map)
        print_ranking(result, args.top)
        outputs = write_outputs(result, args.out, plots=not args.no_plots)
    except DempathError as err:
        print(f'error: {err}', file=sys.stderr)
        return 1
    for p in problems(result):
        print(f'{p.kind} {p.label}: {p.problem or "scored"}{"; " + p.note if p.note else ""}')
    print(f'scores:   {outputs.scores_csv}')
    print(f'table 7:  {outputs.table7_md} ({outputs.table7_csv.name})')
    print(f'workbook: {outputs.workbook}')
    print(f'plots:    {outputs.best_plots[0].parent if outputs.best_plots else "none"} '
          f'({len(outputs.best_plots)} XZ/YZ, {len(outputs.tracked_plots)} 3D)')
    print(f'report:   {outputs.report}')
    return 0


def main(argv: list[str] | None = None) -> int:
    """Run as ``python -m dempath_compare.cli``."""
    return compare_main(sys.argv[1:] if argv is None else argv)


if __name__ == '__main__':
    raise SystemExit(main())
