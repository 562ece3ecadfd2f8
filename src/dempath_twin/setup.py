"""ament_python package dempath_twin."""

from pathlib import Path

from setuptools import find_packages, setup

PACKAGE = 'dempath_twin'
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
    ],
    # PyPI names of the third-party imports; package.xml holds their rosdep keys
    install_requires=[
        'numpy',
        'numba',
        'opencv-contrib-python-headless',
        'pyyaml',
        'rosbags',
    ],
    extras_require={'mlp': ['torch']},  # the paper's MLP reconstructor (optional)
    zip_safe=False,
    maintainer='dempath developers',
    maintainer_email='dempath@users.noreply.github.com',
    description=DESCRIPTION,
    license='Apache-2.0',
    entry_points={
        'dempath.commands': [
            'rig = dempath_twin.cli:rig_main',
            'twin = dempath_twin.cli:twin_main',
        ],
    },
)
