"""Build the interface packages under ``interfaces/`` (``tf2_msgs``, ``track_msgs``) into this venv.

Why: ``tf2_msgs`` (the type of ``/tf`` and ``/tf_static``) is not on PyPI, but the rosidl
generators are, so we build it ourselves with cmake and the machine's compilers, straight into
the venv prefix (docs/DESIGN.md, "Building tf2_msgs"). Run by ``make install`` through
a stamp that depends on the ROS wheel pins and the interface files.

Steps, every run (the script is idempotent: running it twice gives the same venv):

1. Patch the exported ``*.cmake`` files under ``<venv>/share``: the ROS wheels were built under
   manylinux and name that machine's Python and numpy include directories
   (``/opt/python/cp311-cp311/...``), which do not exist here, so generation fails with
   "includes non-existent path". They are replaced by this venv's
   ``sysconfig.get_paths()["include"]`` and ``numpy.get_include()``. Reinstalling a wheel
   restores the foreign paths, hence every run, not once.
2. For each package: configure a fresh build tree under ``build/interfaces/<pkg>`` with
   ``BUILD_TESTING=OFF`` (the lint packages are not installed), build, install into the venv.

Usage: ``.venv/bin/python3 tools/build_interfaces.py [--venv .venv] [PKG ...]``.
Must run with the venv's own interpreter (its numpy and include paths are the ones patched in).
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
INTERFACES = ROOT / 'interfaces'
# Include directories of the manylinux build machine, as the wheels' exported cmake files name them.
FOREIGN_PYTHON_INCLUDE = re.compile(r'/opt/python/cp\d+-cp\d+/include/python3\.\d+')
FOREIGN_NUMPY_INCLUDE = re.compile(r'/opt/python/cp\d+-cp\d+/lib/python3\.\d+/site-packages/numpy/_core/include')


def patch_include_paths(share: Path, python_include: str, numpy_include: str) -> int:
    """Replace the foreign include directories in every ``*.cmake`` under ``share``; → files changed."""
    changed = 0
    for path in sorted(share.rglob('*.cmake')):
        text = path.read_text(encoding='utf-8')
        new = FOREIGN_NUMPY_INCLUDE.sub(numpy_include, text)  # the longer pattern first
        new = FOREIGN_PYTHON_INCLUDE.sub(python_include, new)
        if new != text:
            path.write_text(new, encoding='utf-8')
            changed += 1
    return changed


def build_package(pkg: Path, venv: Path, build_root: Path) -> None:
    """Configure, build and install one ament_cmake interface package into ``venv``."""
    build = build_root / pkg.name
    shutil.rmtree(build, ignore_errors=True)  # a fresh tree: no stale cache from other pins
    env = dict(os.environ, AMENT_PREFIX_PATH=str(venv), CMAKE_PREFIX_PATH=str(venv))
    python = venv / 'bin' / 'python3'
    commands = [
        ['cmake', '-S', str(pkg), '-B', str(build), f'-DCMAKE_INSTALL_PREFIX={venv}',
         f'-DPython3_EXECUTABLE={python}', '-DBUILD_TESTING=OFF', '-DCMAKE_BUILD_TYPE=Release'],
        ['cmake', '--build', str(build), '-j2'],
        ['cmake', '--install', str(build)],
    ]
    for cmd in commands:
        result = subprocess.run(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        if result.returncode != 0:
            sys.stderr.write(result.stdout[-4000:])
            raise SystemExit(f'build_interfaces: {pkg.name}: {" ".join(cmd[:2])} failed '
                             f'(exit {result.returncode})')


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description='Build interfaces/<pkg> into the venv (see the module docstring).')
    ap.add_argument('--venv', type=Path, default=Path(sys.prefix), help='venv prefix (default: this interpreter)')
    ap.add_argument('packages', nargs='*', help='package names (default: every folder of interfaces/)')
    args = ap.parse_args(argv)
    import numpy

    venv = args.venv.resolve()
    if not (venv / 'share').is_dir():
        raise SystemExit(f'build_interfaces: {venv}: no share/ folder (not a venv with the ROS wheels)')
    n = patch_include_paths(venv / 'share', sysconfig.get_paths()['include'], numpy.get_include())
    print(f'build_interfaces: patched the include paths of {n} cmake files under {venv / "share"}')
    names = args.packages or sorted(p.name for p in INTERFACES.iterdir() if (p / 'package.xml').is_file())
    for name in names:
        start = time.monotonic()
        build_package(INTERFACES / name, venv, ROOT / 'build' / 'interfaces')
        print(f'build_interfaces: {name} built and installed into {venv} in {time.monotonic() - start:.1f} s')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
