"""ament_python package dempath."""

from pathlib import Path

from setuptools import find_packages, setup

PACKAGE = 'dempath'

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
        'pyyaml',
        'opencv-contrib-python-headless',
        'rosbags',
        'mcap',
        'zlib-ng',
        "backports.zstd; python_version < '3.14'",
    ],
    zip_safe=False,
    maintainer='dempath developers',
    maintainer_email='dempath@users.noreply.github.com',
    description=Path('package.xml').read_text().split('<description>')[1].split('</description>')[0],
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
        'dempath = dempath.cli:main',
        'dempath_player = dempath.nodes.player:main',
        'dempath_recorder = dempath.nodes.recorder:main',
        ],
        'dempath.commands': [
            'play = dempath.commands:play_main',
            'record = dempath.commands:record_main',
            'bag-info = dempath.commands:bag_info_main',
            'bag-recover = dempath.commands:bag_recover_main',
        ],
    },
)
