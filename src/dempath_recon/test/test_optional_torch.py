"""recon-train: torch is optional (without it the triangulation methods work and asking for the MLP
gives one clear line; a real process in which ``import torch`` fails, as without the extra), and
the training shows its progress."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from dempath_calib.pointset import PointSet, save_point_set

WITHOUT_TORCH = ("import sys; sys.modules['torch'] = None; from dempath.cli import main; "
                 'sys.exit(main(sys.argv[1:]))')


def _dempath_without_torch(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, '-c', WITHOUT_TORCH, *args], capture_output=True,
                          text=True, check=False, timeout=300)


def test_mlp_without_torch_is_one_line(points: PointSet, tmp_path: Path) -> None:
    """recon-train --method mlp without torch: exit 1, one error line naming the extra."""
    ps = save_point_set(tmp_path / 'ps.npz', points)
    done = _dempath_without_torch('recon-train', str(ps), '--method', 'mlp', '--out',
                                  str(tmp_path / 'mlp.pt'))
    assert done.returncode == 1, done.stderr
    assert done.stderr.strip().splitlines() == [
        "error: method: 'mlp' needs torch, which is not installed: pip install 'torch' "
        "(dempath_recon's extra 'mlp'; in this repository: requirements-mlp.txt, installed by "
        'make setup)']
    assert not (tmp_path / 'mlp.pt').exists()


def test_triangulation_without_torch(points: PointSet, tmp_path: Path) -> None:
    """recon-train --method dlt (resection) works in a process where torch cannot be imported."""
    ps = save_point_set(tmp_path / 'ps.npz', points)
    done = _dempath_without_torch('-q', 'recon-train', str(ps), '--method', 'dlt', '--out',
                                  str(tmp_path / 'cams.yaml'))
    assert done.returncode == 0, done.stderr
    assert (tmp_path / 'cams.yaml').is_file()


def test_recon_train_shows_its_progress(points: PointSet, tmp_path: Path) -> None:
    """``dempath recon-train`` logs every epoch (epoch k/n) without -v: its progress."""
    ps = save_point_set(tmp_path / 'ps.npz', points)
    done = subprocess.run([str(Path(sys.executable).with_name('dempath')), 'recon-train', str(ps),
                           '--method', 'mlp', '--mlp-epochs', '2', '--mlp-hidden', '16', '--out',
                           str(tmp_path / 'mlp.pt')], capture_output=True, text=True,
                          check=False, timeout=300)
    assert done.returncode == 0, done.stderr
    prefix = 'INFO dempath_recon.methods.nets: '
    epochs = [ln for ln in done.stderr.splitlines() if ln.startswith(prefix)]
    assert [ln.split(': ')[1].split(':')[0] for ln in epochs] == ['epoch 1/2', 'epoch 2/2']
