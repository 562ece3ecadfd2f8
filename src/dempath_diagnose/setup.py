"""ament_python package dempath_diagnose."""

from pathlib import Path

from setuptools import find_packages, setup

PACKAGE = 'dempath_diagnose'
DESCRIPTION = Path('package.xml').read_text().split('<description>')[1].split('</description>')[0]

setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    package_data={PACKAGE: ['py.typed', 'data/libraries/*.npz']},
    data_files=[
        ('share/ament_index/resource_index/packages', [f'resource/{PACKAGE}']),
        (f'share/{PACKAGE}', ['package.xml']),
    ],
    # PyPI names of the third-party imports; package.xml holds their rosdep keys
    install_requires=[
        'numpy',
        'scipy',
        'scikit-learn',
        'matplotlib',
        'openpyxl',
        'pyyaml',
        'rich',
        'dask',
        'distributed',
        'cma',
        'scoringrules',
    ],
    zip_safe=False,
    maintainer='dempath developers',
    maintainer_email='dempath@users.noreply.github.com',
    description=DESCRIPTION,
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'dempath_diagnoser = dempath_diagnose.nodes.diagnoser:main',
        ],
        'dempath.commands': [
            'diagnose = dempath_diagnose.cli:diagnose_main',
            'recalibrate = dempath_diagnose.recalibrate_cli:recalibrate_main',
        ],
    },
)
