"""The report's per-marker detection coverage: which markers were reconstructed, and when."""

from __future__ import annotations

from pathlib import Path

from dempath_bringup.figures import marker_coverage, plot_marker_coverage


def test_coverage_counts_the_frames_of_the_whole_pass(tmp_path: Path) -> None:
    """Every frame from the first 3D frame to the last counts, a frame with no point at all
    too; a marker seen in 80 % of them is reconstructed, one lost early is not."""
    rows = ['t,marker,x,y,z']
    for f in range(20):
        if f == 7:
            continue  # no 3D point at all in frame 7
        rows += [f'{0.02 * f:.6f},{m},0.0,0.0,0.0' for m in (1, 2) if m == 1 or f < 8]
    (tmp_path / 'measured.csv').write_text('\n'.join(rows) + '\n')
    cov = marker_coverage(tmp_path / 'measured.csv', markers=3)
    assert cov['frames'] == 20
    assert cov['share'] == {1: 0.95, 2: 0.35, 3: 0.0}
    assert cov['reconstructed'] == [1]
    assert not cov['present'][1][7] and cov['present'][2][6] and not cov['present'][2][8]
    assert plot_marker_coverage(cov, tmp_path / 'coverage.png').stat().st_size > 1000
