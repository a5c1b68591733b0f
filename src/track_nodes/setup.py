"""ament_python package track_nodes: rclpy nodes, recorder, player and launcher.

Each executable in NODES gets a small sh shim in lib/track_nodes/ so that
``ros2 run track_nodes <node>`` finds it (ros2 run only looks in <prefix>/lib/<pkg>/).
"""
from pathlib import Path

from setuptools import find_packages, setup

PKG = 'track_nodes'
HERE = Path(__file__).parent
SHIMS = sorted(str(p.relative_to(HERE)) for p in (HERE / 'shims').iterdir())

setup(
    name=PKG,
    version='0.1.0',
    packages=find_packages(exclude=['test', 'test.*']),
    data_files=[
        ('share/ament_index/resource_index/packages', [f'resource/{PKG}']),
        (f'share/{PKG}', ['package.xml']),
        (f'share/{PKG}/launch', sorted(str(p.relative_to(HERE)) for p in (HERE / 'launch').glob('*.py'))),
        (f'share/{PKG}/config', sorted(str(p.relative_to(HERE)) for p in (HERE / 'config').glob('*.yaml'))),
        (f'share/{PKG}/displays', sorted(str(p.relative_to(HERE)) for p in (HERE / 'displays').glob('*.*'))),
        (f'lib/{PKG}', SHIMS),
    ],
    install_requires=['track_core', 'track_msgs_py', 'PyYAML', 'rosbags', 'mcap', 'mcap-ros2-support', 'sllurp',
                      'foxglove-sdk', 'pyais', 'websockets'],
    extras_require={'test': ['pytest']},  # colcon test runs pytest (the suite's part in pytest.ini)
    zip_safe=False,
    description='rclpy nodes of the tracking package set',
    license='BSD-3-Clause',
    entry_points={
        'console_scripts': [
            'track-launch = track_nodes.launch.launcher:main',
            'track-record = track_nodes.bag.recorder:main',
            'track-play = track_nodes.bag.player:main',
            'track-bag-recover = track_nodes.bag.recover:main',
            'track-bag-check = track_nodes.bag.check:main',
            'track-dataset = track_nodes.bag.dataset:main',
            'track-foxglove = track_nodes.foxglove.bridge:main',
            'track-summary = track_nodes.report.summary:main',
            'track-nmea-play = track_nodes.fusion.nmea_play:main',
        ],
    },
)
