"""What colcon and rosdep read from each package (issue 19 items 12-13).

``colcon test`` runs pytest in the package directory, so each package has a pytest.ini naming its
part of ``test/``; it must carry the options of ``pyproject.toml`` (what ``make test`` uses), and
the three parts together must be the whole suite. package.xml declares, as rosdep keys, what the
package's code (exec, buildtool) and its part of the tests (test) import, and nothing else.
"""

import ast
import configparser
import shlex
import sys
import tomllib

import pytest

PKGS = ('track_core', 'track_msgs_py', 'track_nodes', 'track_experiments')


def package_ini(repo, pkg) -> dict:
    ini = configparser.ConfigParser(interpolation=None)
    ini.read(repo / 'src' / pkg / 'pytest.ini')
    return dict(ini['pytest'])


def _lines(value) -> list[str]:
    return [v.strip() for v in value.strip().splitlines() if v.strip()] if isinstance(value, str) else list(value)


@pytest.mark.parametrize('pkg', PKGS)
def test_package_pytest_ini_has_the_options_of_pyproject(repo, pkg):
    root = tomllib.loads((repo / 'pyproject.toml').read_text())['tool']['pytest']['ini_options']
    ini = package_ini(repo, pkg)
    assert set(ini) == set(root), f'{pkg}/pytest.ini and pyproject.toml name different options'
    assert shlex.split(ini['addopts']) == shlex.split(root['addopts'])
    assert ini['timeout'] == str(root['timeout'])
    for key in ('filterwarnings', 'markers'):
        assert _lines(ini[key]) == _lines(root[key]), key


def test_the_packages_test_parts_are_the_whole_suite_once(repo):
    owner = {}
    for pkg in PKGS:
        for rel in package_ini(repo, pkg)['testpaths'].split():
            part = (repo / 'src' / pkg / rel).resolve()
            assert part.is_dir() and part.is_relative_to(repo / 'test'), f'{pkg}: {rel}'
            for test_file in part.rglob('test_*.py'):
                assert test_file not in owner, f'{test_file} is in {owner[test_file]} and {pkg}'
                owner[test_file] = pkg
    assert set(owner) == set((repo / 'test').rglob('test_*.py'))


@pytest.mark.parametrize('pkg', PKGS)
def test_pytest_is_a_test_dependency_colcon_sees(repo, pkg):
    """colcon picks its pytest step only when setup data declare pytest a test dependency."""
    from colcon_core.task.python.test import has_test_dependency
    from colcon_python_setup_py.package_identification.python_setup_py import get_setup_information

    assert has_test_dependency(get_setup_information(repo / 'src' / pkg / 'setup.py'), 'pytest')


# rosdep keys of the imports not named as they import (ROS packages are: rclpy, std_msgs, launch, ...).
# Checked against the rosdistro rosdep/python.yaml and jazzy/distribution.yaml (README, "colcon workspace").
KEYS = {
    'numpy': 'python3-numpy', 'scipy': 'python3-scipy', 'matplotlib': 'python3-matplotlib', 'tqdm': 'python3-tqdm',
    'yaml': 'python3-yaml', 'shapely': 'python3-shapely', 'setuptools': 'python3-setuptools',
    'rosbags': 'python3-rosbags-pip', 'pytest': 'python3-pytest', 'mcap_ros2': 'mcap-ros2-support',
    'catkin_pkg': 'python3-catkin-pkg', 'colcon_core': 'python3-colcon-common-extensions',
    'colcon_python_setup_py': 'python3-colcon-common-extensions', 'pyproj': 'python3-pyproj',
    'ruamel': 'python3-ruamel.yaml',
}
# pip only: a comment in package.xml, the pip step in README
NO_KEY = {'mcap', 'sllurp', 'llrpkit', 'foxglove', 'websockets', 'pyais', 'pytransform3d'}
OPTIONAL = {'stonesoup', 'filterpy', 'gtsam'}  # track-bench's and track-experiment's peers, requirements-bench.txt
NOT_IMPORTED = {'python3-pytest-timeout',  # the pytest plugin of pytest.ini's timeout
                'ros2launch'}  # what runs launch/*.launch.py


def _imports(files, *, module_level_only: bool = False) -> set[str]:
    """Top-level names of the third-party modules ``files`` import (lazy imports too, unless module-level only)."""
    names = set()
    for path in files:
        tree = ast.parse(path.read_text(), str(path))
        for node in tree.body if module_level_only else ast.walk(tree):
            if isinstance(node, ast.Import):
                names |= {alias.name.partition('.')[0] for alias in node.names}
            elif isinstance(node, ast.ImportFrom) and node.level == 0:
                names.add(node.module.partition('.')[0])
    return names - set(sys.stdlib_module_names) - {'conftest', '__future__'}


def _keys(names, pkg) -> set[str]:
    return {KEYS.get(n, n) for n in names - NO_KEY - OPTIONAL - {pkg}}


def _manifest(repo, pkg):
    from catkin_pkg.package import parse_package

    return parse_package(repo / 'src' / pkg / 'package.xml')


def _test_imports(repo, pkg) -> set[str]:
    """What the package's part of the suite imports; of test/conftest.py, what its fixtures in use import
    (all of it for track_nodes, whose tests use them all; the module level for the other two)."""
    files = [f for rel in package_ini(repo, pkg)['testpaths'].split() for f in (repo / 'src' / pkg / rel).rglob('*.py')]
    conftest = repo / 'test/conftest.py'
    return _imports(files) | _imports([conftest], module_level_only=pkg != 'track_nodes')


@pytest.mark.parametrize('pkg', PKGS)
def test_package_xml_declares_what_the_code_imports_and_nothing_else(repo, pkg):
    manifest = _manifest(repo, pkg)
    manifest.validate()
    names = lambda deps: {d.name for d in deps}  # noqa: E731
    run, build, test = names(manifest.exec_depends), names(manifest.buildtool_depends), names(manifest.test_depends)
    code = [p for p in (repo / 'src' / pkg).rglob('*.py') if p.name != 'setup.py']
    need_run = _keys(_imports(code), pkg)
    need_build = _keys(_imports([repo / 'src' / pkg / 'setup.py']), pkg)
    need_test = _keys(_test_imports(repo, pkg), pkg)
    assert need_run <= run, f'{pkg}: imported, no exec_depend: {sorted(need_run - run)}'
    assert need_build <= build, f'{pkg}: setup.py imports, no buildtool_depend: {sorted(need_build - build)}'
    assert need_test <= run | test, f'{pkg}: tests import, not declared: {sorted(need_test - run - test)}'
    stale = (run | build | test) - need_run - need_build - need_test - NOT_IMPORTED
    assert not stale, f'{pkg}: declared, never imported: {sorted(stale)}'
    xml = (repo / 'src' / pkg / 'package.xml').read_text()
    for name in _imports(code) & NO_KEY:
        assert f'{name} (' in xml and f'pip install {name}' in (repo / 'README.md').read_text(), name


@pytest.mark.parametrize('pkg', PKGS)
def test_package_xml_maintainer_and_license_are_the_repositorys(repo, pkg):
    manifest = _manifest(repo, pkg)
    listed = [ln for ln in (repo / 'MAINTAINERS').read_text().splitlines() if ln.strip() and not ln.startswith('#')]
    assert [f'{m.name} <{m.email}>' for m in manifest.maintainers] == listed
    assert not any(m.email.endswith('.invalid') for m in manifest.maintainers)
    assert [str(lic) for lic in manifest.licenses] == ['BSD-3-Clause']
    text = (repo / 'LICENSE').read_text()
    assert text.startswith('BSD 3-Clause License') and 'Copyright (c) 2026, The tracking package set authors' in text
