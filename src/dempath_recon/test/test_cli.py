"""The offline commands: report, train, reconstruct, and their one-line errors."""

from __future__ import annotations

import csv
import json

import numpy as np

from dempath_calib.pointset import save_point_set
from dempath_recon.cli import reconstruct_main, report_main, train_main


def test_report_writes_table_json_and_histogram(points, tmp_path, capsys) -> None:
    """recon-report: every method scored on the held-out rows, Table 5 beside, PNG written."""
    ps = save_point_set(tmp_path / 'ps.npz', points)
    out = tmp_path / 'rep'
    code = report_main([str(ps), '--out', str(out), '--methods', 'dlt,dlt_residual,mlp',
                        '--mlp-epochs', '3', '--mlp-hidden', '32'])
    assert code == 0
    data = json.loads((out / 'report.json').read_text())
    names = [m['name'] for m in data['methods']]
    assert names == ['dlt', 'dlt_residual', 'mlp']
    assert data['paper_table5']['max_mm'] == 23.9
    dlt = data['methods'][0]
    assert dlt['n_test'] == round(4000 * 4149 / 94939)
    assert dlt['mean_mm'] < 0.5 and dlt['max_mm'] < 3.0
    assert (out / 'error_histogram.png').read_bytes()[:4] == b'\x89PNG'
    assert '| mean 3D error [mm] | 2.9 |' in capsys.readouterr().out


def test_train_then_reconstruct_csv(points, rig, tmp_path) -> None:
    """recon-train (dlt, resected) then reconstruct: CSV columns kept, x,y,z and sigma added."""
    ps = save_point_set(tmp_path / 'ps.npz', points)
    cams = tmp_path / 'cams.yaml'
    assert train_main([str(ps), '--method', 'dlt', '--out', str(cams)]) == 0
    truth = points.xyz[:3]
    px = tmp_path / 'px.csv'
    with open(px, 'w', newline='') as fh:
        w = csv.writer(fh)
        w.writerow(['t', 'marker', 'xs', 'ys', 'xf', 'yf'])
        for k, row in enumerate(points.pixels[:3]):
            w.writerow([0.02 * k, 7, *row])
    out = tmp_path / 'xyz.csv'
    assert reconstruct_main([str(px), '--calibration', str(cams), '--out', str(out),
                             '--sigma']) == 0
    with open(out, newline='') as fh:
        rows = list(csv.DictReader(fh))
    assert rows[0]['marker'] == '7'
    xyz = np.array([[float(r[c]) for c in 'xyz'] for r in rows])
    assert np.abs(xyz - truth).max() < 2e-3
    assert all(0 < float(r['sigma_x']) < 0.01 for r in rows)


def test_bad_inputs_give_one_error_line(tmp_path, capsys) -> None:
    """Missing point set, missing model, corrupt calibration: 'error: <file>: ...' and 1."""
    bad_yaml = tmp_path / 'bad.yaml'
    bad_yaml.write_text(': : :\n- [')
    px = tmp_path / 'px.csv'
    px.write_text('xs,ys,xf,yf\n1,2,3,4\n')
    calls = [
        (train_main, [str(tmp_path / 'none.npz'), '--out', str(tmp_path / 'm.pt')], 'none.npz'),
        (reconstruct_main, [str(px), '--method', 'mlp', '--model', str(tmp_path / 'm.pt'),
                            '--out', str(tmp_path / 'o.csv')], 'm.pt'),
        (reconstruct_main, [str(px), '--calibration', str(bad_yaml),
                            '--out', str(tmp_path / 'o.csv')], 'bad.yaml'),
        (reconstruct_main, [str(tmp_path / 'no.csv'), '--calibration', str(bad_yaml),
                            '--out', str(tmp_path / 'o.csv')], 'no.csv'),
    ]
    for func, argv, name in calls:
        capsys.readouterr()
        assert func(argv) == 1
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith('error: ') and name in err[0], err
