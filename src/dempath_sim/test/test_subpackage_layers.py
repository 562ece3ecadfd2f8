"""The sub-packages of dempath_sim import only the ones below them (docs/dem.md, Code layout)."""

from __future__ import annotations

import ast
from pathlib import Path

import dempath_sim

ROOT = Path(dempath_sim.__file__).parent
# Bottom to top: a part may import itself and the parts before it, never one after it.
LAYERS = ('errors', 'effects', 'engine', 'scene', 'runs', 'liggghts', 'validation')


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


def test_no_part_imports_a_higher_one() -> None:
    """engine < scene < runs < liggghts < validation: none reaches up (imports read from ast)."""
    wrong = []
    for level, part in enumerate(LAYERS):
        files = [ROOT / f'{part}.py'] if (ROOT / f'{part}.py').is_file() else sorted(
            (ROOT / part).rglob('*.py'))
        assert files, part
        for path in files:
            higher = _imported_parts(path) & set(LAYERS[level + 1:])
            wrong += [f'{path.relative_to(ROOT)} imports {sorted(higher)}'] if higher else []
    assert not wrong, wrong


def test_cores_do_not_import_back() -> None:
    """simconfig and the scene reader do not import cli.py; report.py does not import the
    validation CLI; the scene records do not import the loader."""
    for path in [ROOT / 'simconfig.py', *sorted((ROOT / 'scene').rglob('*.py'))]:
        assert 'cli' not in _imported_parts(path), path
    assert 'dempath_sim.validation.cli' not in _imported_modules(
        ROOT / 'validation' / 'report.py')
    assert 'dempath_sim.scene.loader' not in _imported_modules(ROOT / 'scene' / 'spec.py')
