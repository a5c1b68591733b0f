"""tools/docstring_lengths.py: module docstrings stay reference text (at most 5 over 30 lines in src/)."""

import importlib.util
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]


def _tool():
    spec = importlib.util.spec_from_file_location('docstring_lengths', ROOT / 'tools/docstring_lengths.py')
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_counts_the_lines_of_a_module_docstring(tmp_path):
    tool = _tool()
    (tmp_path / 'long.py').write_text('"""One.\n\n' + 'line\n' * 40 + '"""\n\nX = 1\n')
    (tmp_path / 'short.py').write_text('"""One line."""\nX = 1\n')
    (tmp_path / 'none.py').write_text('X = 1\n"""not a docstring"""\n')
    (tmp_path / 'empty.py').write_text('')
    assert tool.docstring_lines(tmp_path / 'long.py') == 43
    assert tool.docstring_lines(tmp_path / 'short.py') == 1
    assert tool.docstring_lines(tmp_path / 'none.py') == 0
    assert [p.name for _, p in tool.long_docstrings(tmp_path, 30)] == ['long.py']
    assert tool.main(['--root', str(tmp_path), '--lines', '30', '--allow', '0']) == 1
    assert tool.main(['--root', str(tmp_path), '--lines', '30', '--allow', '1']) == 0


def test_at_most_five_modules_in_src_open_with_more_than_30_lines():
    tool = _tool()
    over = tool.long_docstrings(ROOT / 'src', 30)
    assert len(list((ROOT / 'src').rglob('*.py'))) > 100  # it counts the real tree
    assert len(over) <= 5, [f'{n} {p.relative_to(ROOT)}' for n, p in over]
