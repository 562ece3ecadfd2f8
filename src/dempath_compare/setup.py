"""ament_python package dempath_compare."""

from pathlib import Path

from setuptools import find_packages, setup

PACKAGE = 'dempath_compare'
DESCRIPTION = Path('package.xml').read_text().split('<description>')[1].split('</description>')[0]

setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    package_data={PACKAGE: ['py.typed', 'data/example/*.csv']},
    data_files=[
        ('share/ament_index/resource_index/packages', [f'resource/{PACKAGE}']),
        (f'share/{PACKAGE}', ['package.xml']),
    ],
    # PyPI names of the third-party imports; package.xml holds their rosdep keys
    install_requires=[
        'numpy',
        'numba',
        'matplotlib',
        'openpyxl',
        'rich',
        'dtaidistance',
        'pyyaml',
    ],
    zip_safe=False,
    maintainer='dempath developers',
    maintainer_email='dempath@users.noreply.github.com',
    description=DESCRIPTION,
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'dempath_comparer = dempath_compare.nodes.comparer:main',
        ],
        'dempath.commands': [
            'compare = dempath_compare.cli:compare_main',
        ],
    },
)
