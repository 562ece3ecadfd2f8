"""ament_python package dempath_recon."""

from pathlib import Path

from setuptools import find_packages, setup

PACKAGE = 'dempath_recon'
DESCRIPTION = Path(__file__).with_name('package.xml').read_text().split(
    '<description>')[1].split('</description>')[0]

setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    package_data={PACKAGE: ['py.typed', 'clicker/web/*', 'data/*.pt', 'data/*.json']},
    data_files=[
        ('share/ament_index/resource_index/packages', [f'resource/{PACKAGE}']),
        (f'share/{PACKAGE}', ['package.xml']),
    ],
    # PyPI names of the third-party imports; package.xml holds their rosdep keys
    install_requires=[
        'numpy',
        'scipy',
        'opencv-contrib-python-headless',
        'pillow',
        'matplotlib',
        'simplejpeg',
        'numba',
    ],
    extras_require={'mlp': ['torch']},  # the paper's MLP reconstructor (optional)
    zip_safe=False,
    maintainer='dempath developers',
    maintainer_email='dempath@users.noreply.github.com',
    description=DESCRIPTION,
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'dempath_reconstructor = dempath_recon.nodes.reconstructor:main',
            'dempath_clicker = dempath_recon.nodes.clicker:main',
            'dempath_pass = dempath_recon.nodes.passgate:main',
            'dempath_detector = dempath_recon.nodes.detector:main',
        ],
        'dempath.commands': [
            'reconstruct = dempath_recon.cli:reconstruct_main',
            'recon-train = dempath_recon.cli:train_main',
            'recon-report = dempath_recon.cli:report_main',
            'click = dempath_recon.clicker.cli:click_main',
        ],
    },
)
