"""Each package installs the ROS way: valid package.xml, rosdep keys that exist, pip-only ones in
setup.py, and console scripts in lib/<package> (setup.cfg).

``rosdep install --from-paths src`` aborts on a key it does not know, so every key a package.xml
names must be a ROS package or a key of the rosdep database. ``ROSDEP_KEYS`` holds the keys
dempath uses, each checked by hand against ros/rosdistro's ``rosdep/base.yaml`` and
``rosdep/python.yaml`` (commit 8468e88 of 2026-08-22); ``NO_KEY`` the ones that do not exist
(their packages come from pip, listed in the package's ``install_requires``). Every third-party
module the code imports must be declared one way or the other (docs/ros.md, "Dependencies").
"""

from __future__ import annotations

import ast
import configparser
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from catkin_pkg.package import parse_package

from .import_reading import imported_names

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = tuple(sorted(p.name for p in (ROOT / 'src').iterdir() if (p / 'setup.py').is_file()))
ROSDEP_KEYS = {  # rosdep key -> where it lives in rosdistro (python.yaml unless base.yaml)
    'python3-numpy': 'python', 'python3-scipy': 'python', 'python3-opencv': 'python',
    'python3-matplotlib': 'python', 'python3-yaml': 'python', 'python3-rich': 'python',
    'python3-sklearn': 'python', 'python3-openpyxl': 'python', 'python3-pil': 'python',
    'python3-numba': 'python', 'python3-meshio': 'python', 'python3-torch': 'python',
    'python3-pytest': 'python',
    'python3-selenium': 'python', 'python3-rosbags-pip': 'python (pip)',
    'python3-simplejpeg-pip': 'python (pip)', 'mcap-ros2-support': 'python (pip)',
    'chromium-browser': 'base (Debian: chromium)',
    'chromedriver': 'base (Debian: chromium-driver)',
}
NO_KEY = {'python3-dask', 'python3-distributed', 'chromium', 'chromium-driver', 'python3-cma',
          'python3-dtaidistance', 'python3-mcap', 'python3-simplejpeg', 'python3-rosbags'}
# import name -> (rosdep key or None for pip only, PyPI name)
THIRD_PARTY = {
    'numpy': ('python3-numpy', 'numpy'), 'scipy': ('python3-scipy', 'scipy'),
    'cv2': ('python3-opencv', 'opencv-contrib-python-headless'),
    'matplotlib': ('python3-matplotlib', 'matplotlib'), 'yaml': ('python3-yaml', 'pyyaml'),
    'rich': ('python3-rich', 'rich'), 'sklearn': ('python3-sklearn', 'scikit-learn'),
    'openpyxl': ('python3-openpyxl', 'openpyxl'), 'PIL': ('python3-pil', 'pillow'),
    'numba': ('python3-numba', 'numba'), 'rosbags': ('python3-rosbags-pip', 'rosbags'),
    'simplejpeg': ('python3-simplejpeg-pip', 'simplejpeg'),
    'mcap': (None, 'mcap'), 'zlib_ng': (None, 'zlib-ng'), 'backports': (None, 'backports.zstd'),
    'dtaidistance': (None, 'dtaidistance'), 'cma': (None, 'cma'), 'dask': (None, 'dask'),
    'distributed': (None, 'distributed'), 'meshio': ('python3-meshio', 'meshio'),
    'scoringrules': (None, 'scoringrules'),
}
OPTIONAL = {'torch': 'mlp'}  # import -> the setup.py extra that brings it
ROS_MODULES = {'rclpy', 'builtin_interfaces', 'rcl_interfaces', 'rosgraph_msgs'}
ROS_PACKAGES = {'launch', 'launch_ros', 'ament_index_python'}  # ROS packages (the launch files)
TEST_ONLY = {'pytest', 'selenium', 'mcap_ros2', 'cloudpickle', 'setuptools'}


def package_xml(pkg: str) -> ET.Element:
    return ET.parse(ROOT / 'src' / pkg / 'package.xml').getroot()


def setup_keywords(pkg: str) -> dict[str, object]:
    """The literal keyword arguments of the ``setup(...)`` call in ``pkg``'s setup.py."""
    tree = ast.parse((ROOT / 'src' / pkg / 'setup.py').read_text())
    call = next(n for n in ast.walk(tree) if isinstance(n, ast.Call)
                and getattr(n.func, 'id', '') == 'setup')
    found = {}
    for kw in call.keywords:
        try:
            found[str(kw.arg)] = ast.literal_eval(kw.value)
        except ValueError:
            continue
    return found


def third_party_imports(pkg: str) -> set[str]:
    """Top-level modules imported by the package's code (not its tests), lazy imports too."""
    found = {name.split('.')[0] for path in (ROOT / 'src' / pkg / pkg).rglob('*.py')
             for name in imported_names(path)}
    return {m for m in found if m not in sys.stdlib_module_names and m != '__future__'
            and not m.startswith('dempath') and m not in ROS_MODULES and not m.endswith('_msgs')
            and not m.endswith('_srvs') and m not in TEST_ONLY and m != 'compression'}


@pytest.mark.parametrize('pkg', PACKAGES)
def test_package_xml_is_valid_format_3(pkg: str) -> None:
    """catkin_pkg (what colcon and rosdep read it with) accepts the manifest and its version."""
    manifest = parse_package(ROOT / 'src' / pkg / 'package.xml')
    manifest.validate()
    assert manifest.package_format == 3
    assert manifest.name == pkg
    assert manifest.get_build_type() == 'ament_python'


@pytest.mark.parametrize('pkg', PACKAGES)
def test_every_key_exists(pkg: str) -> None:
    """Keys are ROS packages (dempath's or ROS's ``*_msgs``, rclpy...) or known rosdep keys."""
    keys = {e.text.strip() for e in package_xml(pkg) if e.tag.endswith('depend') and e.text}
    ros = {k for k in keys if k.startswith('dempath') or k in ROS_MODULES | ROS_PACKAGES
           or k.endswith(('_msgs', '_srvs', '_interfaces'))}
    unknown = keys - ros - set(ROSDEP_KEYS)
    assert unknown == set(), f'{pkg}/package.xml: no such rosdep key: {sorted(unknown)}'
    assert keys & NO_KEY == set()


@pytest.mark.parametrize('pkg', PACKAGES)
def test_every_import_is_declared(pkg: str) -> None:
    """Each third-party import is a rosdep key in package.xml and a PyPI name in setup.py
    (install_requires), or pip only (install_requires, named in a package.xml comment)."""
    xml_text = (ROOT / 'src' / pkg / 'package.xml').read_text()
    keys = {e.text.strip() for e in package_xml(pkg) if e.tag == 'exec_depend' and e.text}
    kw = setup_keywords(pkg)
    requires = {str(r).split(';')[0].strip() for r in kw.get('install_requires', [])}
    extras = kw.get('extras_require', {})
    assert isinstance(extras, dict)
    for module in sorted(third_party_imports(pkg)):
        if module in ROS_PACKAGES:  # a ROS install's (the launch description)
            assert module in keys, f'{pkg}/package.xml: exec_depend {module} missing'
            continue
        if module in OPTIONAL:
            assert module in extras.get(OPTIONAL[module], []), f'{pkg}: extra for {module}'
            continue
        assert module in THIRD_PARTY, f'{pkg} imports {module}: add it to THIRD_PARTY'
        key, pypi = THIRD_PARTY[module]
        assert pypi in requires, f'{pkg}/setup.py: install_requires lacks {pypi} ({module})'
        if key is None:
            assert pypi in xml_text, f'{pkg}/package.xml: name pip-only {pypi} in its comment'
        else:
            assert key in keys, f'{pkg}/package.xml: exec_depend {key} missing ({module})'


@pytest.mark.parametrize('pkg', PACKAGES)
def test_setup_cfg_puts_scripts_in_lib(pkg: str) -> None:
    """``ros2 run`` and launch look for executables in lib/<package>, not bin/."""
    cfg = configparser.ConfigParser()
    cfg.read(ROOT / 'src' / pkg / 'setup.cfg')
    assert cfg['develop']['script_dir'] == f'$base/lib/{pkg}'
    assert cfg['install']['install_scripts'] == f'$base/lib/{pkg}'
