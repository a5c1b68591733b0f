"""ament_python package track_core: numerical cores, no ROS imports."""
from setuptools import find_packages, setup

PKG = 'track_core'

setup(
    name=PKG,
    version='0.1.0',
    packages=find_packages(exclude=['test', 'test.*']),
    data_files=[
        ('share/ament_index/resource_index/packages', [f'resource/{PKG}']),
        (f'share/{PKG}', ['package.xml']),
    ],
    install_requires=['numpy', 'scipy', 'matplotlib', 'tqdm'],
    zip_safe=False,
    description='ROS-free numerical cores of the tracking package set',
    license='BSD-3-Clause',
    entry_points={
        'console_scripts': [
            'track-experiment = track_core.cli:experiment_main',
            'track-bench = track_core.cli:bench_main',
        ],
        # Registries: other packages add entries to these groups in their setup.py.
        'track.experiments': [
            'demo-kf = track_core.demo.experiment:nees_experiment',
            'geo-fig2 = track_core.geofeasibility.experiments:fig2',
            'geo-fig5 = track_core.geofeasibility.experiments:fig5',
            'geo-fig6 = track_core.geofeasibility.experiments:fig6',
            'sonar-table2 = track_core.sonar.experiments:table2',
            'smart-target = track_core.sonar.experiments:smart_target',
            'rfid-table1 = track_core.rfid.experiments:table1',
            'rfid-reader = track_core.rfid.reader_experiments:reader_experiment',
            'idsq-table4 = track_core.idsq.experiments:table4',
            'idsq-table5 = track_core.idsq.experiments:table5',
            'idsq-selection = track_core.idsq.experiments:selection',
            'slam-loop = track_core.slam.experiments:slam_loop',
            'victoria-park = track_core.slam.experiments:victoria_park',
            'ais-association = track_core.ais.experiments:ais_association',
        ],
        'track.benchmarks': [
            'kalman = track_core.demo.experiment:kalman_benchmark',
            'geofeasibility = track_core.geofeasibility.benchmark:bench',
            'sonar = track_core.sonar.bench:sonar_benchmark',
            'rfid = track_core.rfid.bench:bench',
            'idsq = track_core.idsq.bench:bench',
            'cekf = track_core.slam.experiments:cekf_bench',
        ],
    },
)
