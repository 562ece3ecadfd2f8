"""ament_python package dempath_bringup."""

from pathlib import Path

from setuptools import find_packages, setup

PACKAGE = 'dempath_bringup'
DESCRIPTION = Path(__file__).with_name('package.xml').read_text().split(
    '<description>')[1].split('</description>')[0]

setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    package_data={PACKAGE: ['py.typed']},
    data_files=[
        ('share/ament_index/resource_index/packages', [f'resource/{PACKAGE}']),
        (f'share/{PACKAGE}', ['package.xml']),
        (f'share/{PACKAGE}/launch', [str(p) for p in sorted(Path('launch').glob('*.launch.py'))]),
        (f'share/{PACKAGE}/config', [str(p) for p in sorted(Path('config').glob('*.yaml'))]),
    ],
    # PyPI names of the third-party imports; package.xml holds their rosdep keys
    install_requires=[
        'numpy',
        'opencv-contrib-python-headless',
        'matplotlib',
        'rich',
    ],
    zip_safe=False,
    maintainer='dempath developers',
    maintainer_email='dempath@users.noreply.github.com',
    description=DESCRIPTION,
    license='Apache-2.0',
    entry_points={
        'dempath.commands': [
            'demo = dempath_bringup.demo:demo_main',
            'frames = dempath_bringup.framescli:frames_main',
        ],
    },
)
