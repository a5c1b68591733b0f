"""What colcon and rosdep read from each package (issue 19 items 12-13).

``colcon test`` runs pytest in the package directory, so each package has a pytest.ini naming its
part of ``test/``; it must carry the options of ``pyproject.toml`` (what ``make test`` uses), and
the three parts together must be the whole suite.
"""

import configparser
import shlex
import tomllib

import pytest

PKGS = ('track_core', 'track_msgs_py', 'track_nodes')


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
