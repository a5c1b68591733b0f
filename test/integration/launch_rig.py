"""ROS 2 ``launch`` and ``launch_ros`` (jazzy) built from their sources into a scratch prefix, for the
tests of our ``ros2 launch`` files through launch's own ``LaunchService``.

They are not on PyPI; their sources are not part of this repository and not on CI machines.
``TRACK_LAUNCH_SOURCES`` names a directory holding checkouts of the jazzy branches of
``launch`` (ros2/launch), ``launch_ros`` (ros2/launch_ros) and ``rcl_interfaces`` (ros2/rcl_interfaces,
for ``composition_interfaces``, which ``launch_ros.actions`` imports and which is not on PyPI
either). Without it the tests skip, saying so.

The build, into ``dest``: the pure-Python ``launch`` and ``launch_ros`` packages and their one
dependency missing from our venv, ``osrf-pycommon`` (PyPI), with pip into ``dest/site``; the
message-only ``composition_interfaces`` with cmake and the rosidl generators of our venv (as
``tools/build_interfaces.py`` builds ours) into ``dest/prefix``. ``env(dest)`` is the environment
that finds them. ``python launch_rig.py SOURCES DEST`` builds by hand.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

SOURCES_ENV = 'TRACK_LAUNCH_SOURCES'
PACKAGES = ('launch/launch', 'launch_ros/launch_ros')
OSRF_PYCOMMON = 'osrf-pycommon==2.0.2'
INTERFACE = 'rcl_interfaces/composition_interfaces'


def sources() -> Path | None:
    """The sources directory, or None when it is not set or lacks a package (the reason: ``missing``)."""
    root = os.environ.get(SOURCES_ENV, '').strip()
    if not root or missing(Path(root)):
        return None
    return Path(root)


def missing(root: Path) -> str | None:
    """Why ``root`` cannot be built from, or None."""
    for rel in (*PACKAGES, INTERFACE):
        if not (root / rel / 'package.xml').is_file():
            return f'{root / rel}/package.xml not found'
    return None


def skip_reason() -> str:
    root = os.environ.get(SOURCES_ENV, '').strip()
    if not root:
        return (f'launch and launch_ros are not on PyPI: set {SOURCES_ENV} to a directory with jazzy checkouts of '
                'launch, launch_ros and rcl_interfaces to test through LaunchService')
    return f'{SOURCES_ENV}={root}: {missing(Path(root))}'


def build(root: Path, dest: Path) -> dict[str, str]:
    """Build everything into ``dest`` (idempotent: a finished build is reused); → ``env(dest)``."""
    done = dest / '.built'
    if done.is_file():
        return env(dest)
    site, prefix = dest / 'site', dest / 'prefix'
    pip = [sys.executable, '-m', 'pip', '-q', '--disable-pip-version-check', 'install', '--target', str(site)]
    _run([*pip, '--no-deps', *[str(root / p) for p in PACKAGES]], 'launch, launch_ros')
    _run([*pip, '--no-deps', OSRF_PYCOMMON], OSRF_PYCOMMON)
    build_dir = dest / 'build'
    venv = Path(sys.prefix)
    cmake_env = dict(os.environ, AMENT_PREFIX_PATH=str(venv), CMAKE_PREFIX_PATH=str(venv))
    for cmd in (['cmake', '-S', str(root / INTERFACE), '-B', str(build_dir), f'-DCMAKE_INSTALL_PREFIX={prefix}',
                 f'-DPython3_EXECUTABLE={sys.executable}', '-DBUILD_TESTING=OFF', '-DCMAKE_BUILD_TYPE=Release'],
                ['cmake', '--build', str(build_dir), '-j2'], ['cmake', '--install', str(build_dir)]):
        _run(cmd, 'composition_interfaces', env=cmake_env)
    shutil.rmtree(build_dir, ignore_errors=True)
    done.write_text('ok\n')
    return env(dest)


def env(dest: Path, base: dict[str, str] | None = None) -> dict[str, str]:
    """``base`` (default: this environment) with the built packages found: Python path, libraries, ament index."""
    base = dict(os.environ if base is None else base)
    pure = sysconfig.get_path('purelib', vars={'base': str(dest / 'prefix')})
    paths = [str(dest / 'site'), pure, pure.replace('site-packages', 'dist-packages')]

    def joined(key: str, *first: str) -> str:
        return os.pathsep.join([*first, *[p for p in base.get(key, '').split(os.pathsep) if p]])

    base['PYTHONPATH'] = joined('PYTHONPATH', *paths)
    base['LD_LIBRARY_PATH'] = joined('LD_LIBRARY_PATH', str(dest / 'prefix/lib'))
    base['AMENT_PREFIX_PATH'] = joined('AMENT_PREFIX_PATH', str(dest / 'prefix')) if base.get(
        'AMENT_PREFIX_PATH') else os.pathsep.join([str(dest / 'prefix'), sys.prefix])
    return base


def _run(cmd: list[str], what: str, env: dict[str, str] | None = None) -> None:
    proc = subprocess.run(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if proc.returncode != 0:
        raise RuntimeError(f'building {what} failed (exit {proc.returncode}): {proc.stdout[-3000:]}')


if __name__ == '__main__':
    print(build(Path(sys.argv[1]), Path(sys.argv[2]))['PYTHONPATH'])
