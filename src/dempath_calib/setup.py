"""ament_python package dempath_calib."""


from setuptools import find_packages, setup

PACKAGE = 'dempath_calib'

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
        'scipy',
        'opencv-contrib-python-headless',
        'pyyaml',
        'rich',
    ],
    zip_safe=False,
    maintainer='dempath developers',
    maintainer_email='dempath@users.noreply.github.com',
    description='Two-camera ChArUco calibration for dempath: intrinsics, stereo, world frame.',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'dempath_calibrator = dempath_calib.nodes.calibrator:main',
        ],
        'dempath.commands': [
            'calibrate = dempath_calib.cli:calibrate_main',
            'calib-check = dempath_calib.checkcli:calib_check_main',
        ],
    },
)
