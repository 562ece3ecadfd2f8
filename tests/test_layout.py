"""The workspace layout rules: ROS stays in nodes/, every package has the ROS 2 package files."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PYTHON_PACKAGES = ('dempath', 'dempath_calib', 'dempath_recon', 'dempath_sim', 'dempath_compare',
                   'dempath_diagnose')
ROS_IMPORT = re.compile(r'^\s*(import|from)\s+(rclpy|\w+_msgs)\b', re.MULTILINE)


def core_modules() -> list[Path]:
    """Every module of the five Python packages outside their nodes/ subpackages."""
    found = []
    for pkg in PYTHON_PACKAGES:
        for path in (ROOT / 'src' / pkg / pkg).rglob('*.py'):
            if 'nodes' not in path.relative_to(ROOT / 'src' / pkg / pkg).parts:
                found.append(path)
    return found


def test_core_modules_do_not_import_ros() -> None:
    """Algorithms import no rclpy and no message package: only nodes/ adapts to ROS."""
    leaks = [str(p.relative_to(ROOT)) for p in core_modules() if ROS_IMPORT.search(p.read_text())]
    assert leaks == [], f'core modules importing ROS: {leaks}'


@pytest.mark.parametrize('pkg', [*PYTHON_PACKAGES, 'dempath_msgs'])
def test_ros_package_files(pkg: str) -> None:
    """Each package is a ROS 2 package (package.xml format 3) named like its folder."""
    xml = (ROOT / 'src' / pkg / 'package.xml').read_text()
    assert '<package format="3">' in xml
    assert f'<name>{pkg}</name>' in xml


def test_ruff_clean() -> None:
    """The code follows the project's lint rules (ruff, configured in pyproject.toml)."""
    import subprocess
    import sys
    from pathlib import Path as _Path

    ruff = _Path(sys.executable).parent / 'ruff'
    done = subprocess.run([str(ruff), 'check', 'src', 'tests', 'bench'], cwd=ROOT,
                          capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stdout[-3000:]
