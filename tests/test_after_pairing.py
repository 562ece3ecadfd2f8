"""A simulated run compared as the demo's 'after': every marker against its own Cube
candidates (the paper's N best), not one particle per marker (issue 26)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from dempath_bringup.analysis import after_model_source
from dempath_compare.pipeline import compare_paths
from dempath_compare.summary import build_table7
from dempath_sim.runs.markers import ROLE_CANDIDATE, ROLE_MARKER
from dempath_sim.runs.results import SimResult

CANDIDATES = 15  # per marker, more than the paper's N = 10


def _run() -> SimResult:
    """Two markers, each with 15 candidates pushed along +Z from 0.1 s at scattered speeds."""
    rng = np.random.default_rng(4)
    times = np.linspace(0.0, 0.5, 26)
    ids, roles, markers, pos = [], [], [], []
    for m, x in ((1, 0.0), (2, 0.05)):
        for k in range(CANDIDATES + 1):
            ids.append(100 * m + k)
            roles.append(ROLE_MARKER if k == 0 else ROLE_CANDIDATE)
            markers.append(m)
            start = np.array([x, 0.0, 0.3]) + rng.uniform(-0.002, 0.002, 3)  # in the cube
            moving = np.clip(times - 0.1, 0.0, None)  # at rest, then pushed along +Z
            path = start + np.outer(moving, [0.0, 0.05, 0.5 + rng.normal(0.0, 0.05)])
            pos.append(path)
    positions = np.stack(pos, axis=1)
    n = positions.shape[1]
    zeros = np.zeros((len(times), 3))
    return SimResult(times, np.array(ids, np.int64), np.array(roles, np.uint8),
                     np.array(markers, np.int32), np.full(n, 0.003), positions,
                     np.zeros_like(positions), zeros, zeros, zeros)


def test_a_run_is_compared_with_every_candidate_of_each_marker(tmp_path: Path) -> None:
    """The demo's 'after' run folder (as ``dempath simulate`` writes it) is compared with each
    marker's own Cube candidates, the N best of them (10 of 16 here); it used to pair every
    marker with one particle (markers.csv), N = 1."""
    run = _run()
    folder = tmp_path / 'model_after'
    folder.mkdir()
    run.write_model_csv(folder / 'model.csv')
    run.write_marker_csv(folder / 'markers.csv')
    run.write_tool_csv(folder / 'tool.csv')
    run.write_marker_csv(tmp_path / 'measured.csv')
    result = compare_paths(tmp_path / 'measured.csv', after_model_source(folder))
    table = build_table7(result)
    assert sorted(r.marker for r in table.rows) == [1, 2]
    assert all(r.n_best == 10 for r in table.rows), [r.n_best for r in table.rows]
    for e, marker in enumerate(result.measured.idents):
        assert (result.model.marker_ids[result.best(e)] == marker).all()


def test_a_simulate_folder_itself_gives_the_model_csv_alone(tmp_path: Path) -> None:
    """``dempath compare`` given the run folder (summary.json beside the CSVs) reads model.csv
    only: markers.csv would pair each marker with one particle and tool.csv is no track."""
    import json

    run = _run()
    folder = tmp_path / 'run'
    folder.mkdir()
    run.write_model_csv(folder / 'model.csv')
    run.write_marker_csv(folder / 'markers.csv')
    run.write_tool_csv(folder / 'tool.csv')
    (folder / 'summary.json').write_text(json.dumps({'run_id': 'r', 'seed': 1}))
    run.write_marker_csv(tmp_path / 'measured.csv')
    result = compare_paths(tmp_path / 'measured.csv', folder)
    table = build_table7(result)
    assert all(r.n_best == 10 for r in table.rows), [r.n_best for r in table.rows]
    assert len(result.model.idents) == 2 * (CANDIDATES + 1)
