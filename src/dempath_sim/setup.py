"""ament_python package dempath_sim."""

from pathlib import Path

from setuptools import find_packages, setup

PACKAGE = 'dempath_sim'

setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    package_data={PACKAGE: ['py.typed', 'data/*.stl', 'data/*.py', 'data/scenes/*.yaml',
                            'data/packings/*.npz', 'data/decks/*/*']},
    data_files=[
        ('share/ament_index/resource_index/packages', [f'resource/{PACKAGE}']),
        (f'share/{PACKAGE}', ['package.xml']),
    ],
    # PyPI names of the third-party imports; package.xml holds their rosdep keys
    install_requires=[
        'numpy',
        'scipy',
        'numba',
        'matplotlib',
        'pyyaml',
        'rich',
        'meshio',
    ],
    zip_safe=False,
    maintainer='dempath developers',
    maintainer_email='dempath@users.noreply.github.com',
    description=Path('package.xml').read_text().split('<description>')[1].split('</description>')[0],
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'dempath_simulator = dempath_sim.nodes.simulator:main',
        ],
        'dempath.commands': [
            'simulate = dempath_sim.cli:simulate_main',
            'effects = dempath_sim.cli:effects_main',
            'liggghts = dempath_sim.liggghts.cli:liggghts_main',
            'validate = dempath_sim.validation.cli:validate_main',
        ],
    },
)
