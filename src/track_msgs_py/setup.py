"""ament_python package track_msgs_py: the only layer that knows core types and ROS messages."""
from setuptools import find_packages, setup

PKG = 'track_msgs_py'

setup(
    name=PKG,
    version='0.1.0',
    packages=find_packages(exclude=['test', 'test.*']),
    data_files=[
        ('share/ament_index/resource_index/packages', [f'resource/{PKG}']),
        (f'share/{PKG}', ['package.xml']),
    ],
    install_requires=['track_core', 'numpy'],
    zip_safe=False,
    description='Topics, QoS, conversions and validation for standard ROS 2 messages',
    license='BSD-3-Clause',
)
