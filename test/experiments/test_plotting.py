"""Figures go through ``track_experiments.plotting.pyplot``: no other experiment sets up matplotlib."""

from pathlib import Path

import track_experiments


def test_one_plotting_helper():
    root = Path(track_experiments.__file__).parent
    own = [p.relative_to(root).as_posix() for p in root.rglob('*.py')
           if p.name != 'plotting.py' and 'matplotlib.use(' in p.read_text()]
    assert (root / 'plotting.py').is_file() and not own, own
