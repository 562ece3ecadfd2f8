"""Cores of dempath_sim that must not import back up (docs/dem.md, Code layout).

The order of dempath_sim's sub-packages (errors < effects < engine < scene < runs < liggghts <
validation) is checked with the other packages' rooms in tests/test_layout.py (``ROOMS``).
"""

from __future__ import annotations

import ast
from pathlib import Path

import dempath_sim

ROOT = Path(dempath_sim.__file__).parent


def _imported_modules(path: Path) -> set[str]:
    """Dotted names of the dempath_sim modules a file imports (``from dempath_sim import x``
    counts as ``dempath_sim.x``)."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module == 'dempath_sim':
            out |= {f'dempath_sim.{a.name}' for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module:
            out.add(node.module)
    return {m for m in out if m.startswith('dempath_sim.')}


def _imported_parts(path: Path) -> set[str]:
    """The dempath_sim parts (first name after ``dempath_sim.``) a file imports."""
    return {m.split('.')[1] for m in _imported_modules(path)}


def test_cores_do_not_import_back() -> None:
    """simconfig and the scene reader do not import cli.py; validation_report.py does not import
    the validation CLI; the scene records do not import the loader."""
    for path in [ROOT / 'simconfig.py', *sorted((ROOT / 'scene').rglob('*.py'))]:
        assert 'cli' not in _imported_parts(path), path
    assert 'dempath_sim.validation.cli' not in _imported_modules(
        ROOT / 'validation' / 'validation_report.py')
    assert 'dempath_sim.scene.loader' not in _imported_modules(ROOT / 'scene' / 'spec.py')
