from pathlib import Path

from track_core import data


def test_env_var_wins(monkeypatch, tmp_path):
    monkeypatch.setenv('TRACK_DATA_DIR', str(tmp_path))
    assert data.data_dir('victoria_park') == tmp_path / 'victoria_park'


def test_found_from_cwd_parents(monkeypatch, tmp_path):
    (tmp_path / 'shared' / 'data').mkdir(parents=True)
    deep = tmp_path / 'main' / 'a' / 'b'
    deep.mkdir(parents=True)
    monkeypatch.delenv('TRACK_DATA_DIR', raising=False)
    monkeypatch.chdir(deep)
    assert data.data_root() == tmp_path / 'shared' / 'data'


def test_repo_layout_is_found(repo):
    # The checkout sits next to ../shared in this project's layout; when it does, it is found.
    expected = Path(repo).resolve().parent / 'shared' / 'data'
    if expected.is_dir():
        assert data.data_root().resolve() == expected
