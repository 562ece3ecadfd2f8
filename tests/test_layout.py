"""The workspace layout rules: ROS stays in nodes/, floors, declared dependencies, package files.

The floors (house style 16, drawn in docs/design.md): a package imports only packages on its own
floor or below, and packages on one floor do not import each other in a cycle. Imports are read
with ``ast``, so imports inside functions (the lazy ones) count too. Every package under ``src/``
with a ``package.xml`` is checked, whichever exist.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from .import_reading import imported_names

ROOT = Path(__file__).resolve().parents[1]
FLOORS = {  # package -> floor; a package may import its own floor and the ones below
    'dempath_msgs': 1, 'dempath': 1,
    'dempath_calib': 2, 'dempath_sim': 2, 'dempath_compare': 2,
    'dempath_recon': 3, 'dempath_twin': 3,
    'dempath_diagnose': 4,
    'dempath_bringup': 5,
}
PYTHON_PACKAGES = tuple(sorted(p.name for p in (ROOT / 'src').iterdir()
                               if (p / 'package.xml').is_file() and (p / p.name).is_dir()))
ROS_PACKAGES = tuple(sorted(p.name for p in (ROOT / 'src').iterdir()
                            if (p / 'package.xml').is_file()))
ROS_IMPORT = re.compile(r'^\s*(import|from)\s+(rclpy|\w+_msgs)\b', re.MULTILINE)


def core_modules() -> list[Path]:
    """Every module of the Python packages outside their nodes/ subpackages."""
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


def imported_packages(folder: Path) -> dict[str, set[str]]:
    """dempath package -> the files under ``folder`` importing it (any depth, lazy included)."""
    found: dict[str, set[str]] = {}
    for path in folder.rglob('*.py'):
        for top in {name.split('.')[0] for name in imported_names(path)} & set(FLOORS):
            found.setdefault(top, set()).add(str(path.relative_to(ROOT)))
    return found


def declared(pkg: str, tags: tuple[str, ...]) -> set[str]:
    """dempath packages named by ``tags`` (e.g. exec_depend) in ``pkg``'s package.xml."""
    root = ET.parse(ROOT / 'src' / pkg / 'package.xml').getroot()
    return {e.text.strip() for tag in tags for e in root.iter(tag)
            if e.text and e.text.strip() in FLOORS}


def test_every_package_has_a_floor() -> None:
    """A new package is placed on a floor (here and in docs/design.md) before it lands."""
    assert set(ROS_PACKAGES) <= set(FLOORS), set(ROS_PACKAGES) - set(FLOORS)


@pytest.mark.parametrize('pkg', PYTHON_PACKAGES)
@pytest.mark.parametrize('part', ['code', 'test'])
def test_no_import_from_a_higher_floor(pkg: str, part: str) -> None:
    """A package (its code and its own tests) imports nothing from a higher floor."""
    folder = ROOT / 'src' / pkg / (pkg if part == 'code' else 'test')
    if not folder.is_dir():
        pytest.skip(f'{pkg} has no {part} folder')
    higher = {dep: sorted(files) for dep, files in imported_packages(folder).items()
              if FLOORS[dep] > FLOORS[pkg]}
    assert higher == {}, f'{pkg} (floor {FLOORS[pkg]}) imports from a higher floor: {higher}'


def test_no_cycle_between_packages() -> None:
    """The package import graph (code only) has no cycle, within a floor either."""
    graph = {pkg: set(imported_packages(ROOT / 'src' / pkg / pkg)) - {pkg}
             for pkg in PYTHON_PACKAGES}
    done: set[str] = set()

    def visit(pkg: str, path: tuple[str, ...]) -> None:
        assert pkg not in path, f'import cycle: {" -> ".join((*path, pkg))}'
        if pkg not in done:
            for dep in graph.get(pkg, ()):
                visit(dep, (*path, pkg))
            done.add(pkg)

    for pkg in graph:
        visit(pkg, ())


# The rooms inside a package (or inside one of its sub-packages), bottom to top: a room (a
# sub-package or a module) imports the rooms of its own package only from the ones before it.
# Modules not named here (a CLI, nodes/, modules not yet in a room) sit above every room: a room
# may not import them.
ROOMS = {
    'dempath_sim': ('errors', 'effects', 'engine', 'scene', 'runs', 'liggghts', 'validation'),
    'dempath_sim.runs.bed': ('pour', 'measure', 'standing_tool', 'packing_file', 'settle', 'cache',
                             'fill', 'placement'),
    'dempath_recon': ('errors', 'methods', 'tracking', 'clicker'),
    'dempath_twin': ('errors', 'rig', 'images', 'board', 'field', 'render'),
    'dempath_diagnose': ('errors', 'records', 'admission', 'library', 'decision', 'headline',
                         'recalibration', 'report', 'separation', 'next_runs', 'adaptive',
                         'entry'),
    'dempath_bringup': ('frames', 'truth', 'calibstep', 'figures', 'launchgraph', 'nodes',
                        'context', 'stages', 'report', 'analysis'),
}
# Known crossings still to mend, each named by file: (package, file under the package) -> rooms
# (none now: a new one is named here with the reason, and mended).
CROSSINGS: dict[tuple[str, str], set[str]] = {}


def own_parts(path: Path, package: str) -> set[str]:
    """The parts of ``package`` (dotted; the first name after it) a file imports, lazy too."""
    return {n[len(package) + 1:].split('.')[0] for n in imported_names(path)
            if n.startswith(f'{package}.')}


def part_files(package: str, part: str) -> list[Path]:
    """The files of one part of ``package`` (dotted): a module or every file of a sub-package."""
    top = package.split('.')[0]
    base = ROOT / 'src' / top / Path(*package.split('.'))
    return [base / f'{part}.py'] if (base / f'{part}.py').is_file() else sorted(
        (base / part).rglob('*.py'))


@pytest.mark.parametrize('package', sorted(ROOMS))
def test_rooms_import_only_the_rooms_below(package: str) -> None:
    """Inside a package, a room imports itself and the rooms listed before it, nothing else."""
    rooms = ROOMS[package]
    wrong = []
    for level, room in enumerate(rooms):
        files = part_files(package, room)
        assert files, f'{package}: room {room!r} is neither a module nor a sub-package'
        allowed = set(rooms[:level + 1])
        for path in files:
            rel = path.relative_to(ROOT / 'src' / package.split('.')[0] / package.split('.')[0])
            bad = own_parts(path, package) - allowed - CROSSINGS.get((package, str(rel)), set())
            wrong += [f'{path.relative_to(ROOT)} imports {sorted(bad)}'] if bad else []
    assert not wrong, wrong


@pytest.mark.parametrize('pkg', PYTHON_PACKAGES)
def test_package_xml_declares_what_is_imported(pkg: str) -> None:
    """Code imports -> exec_depend; test-only imports -> exec_depend or test_depend."""
    run = declared(pkg, ('exec_depend', 'depend'))
    code = set(imported_packages(ROOT / 'src' / pkg / pkg)) - {pkg}
    assert code <= run, f'{pkg}/package.xml lacks exec_depend on {sorted(code - run)}'
    test_dir = ROOT / 'src' / pkg / 'test'
    tests = set(imported_packages(test_dir)) - {pkg} if test_dir.is_dir() else set()
    both = run | declared(pkg, ('test_depend',))
    assert tests <= both, f'{pkg}/package.xml lacks test_depend on {sorted(tests - both)}'


@pytest.mark.parametrize('pkg', ROS_PACKAGES)
def test_package_xml_depends_only_downwards(pkg: str) -> None:
    """Declared dempath dependencies point to the same floor or below, never up."""
    deps = declared(pkg, ('exec_depend', 'depend', 'build_depend', 'test_depend')) - {pkg}
    up = sorted(d for d in deps if FLOORS[d] > FLOORS[pkg])
    assert up == [], f'{pkg}/package.xml depends on higher floors: {up}'


@pytest.mark.parametrize('pkg', ROS_PACKAGES)
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


def test_nothing_below_a_command_takes_parsed_arguments() -> None:
    """argparse.Namespace and redirect_stdout stay in the commands (a module with a ``*_main``
    or a ``*cli*`` module): below them, typed requests and results (house style)."""
    found = []
    for path in core_modules():
        text = path.read_text()
        command = re.search(r'^def \w+_main\(', text, re.MULTILINE) or 'cli' in path.stem
        if not command and ('argparse.Namespace' in text or 'redirect_stdout' in text):
            found.append(str(path.relative_to(ROOT)))
    assert found == [], f'parsed arguments or captured stdout below a command: {found}'
