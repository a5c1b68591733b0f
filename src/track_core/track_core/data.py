"""Where the real data sets live: a data folder outside the repository (``shared/data`` beside the checkout).

The data are read at run time and never copied into the project. Because the packages are
installed non-editable into ``.venv``, ``__file__`` does not point into the checkout, so the
directory is found in this order:

1. ``$TRACK_DATA_DIR`` (the folder holding ``victoria_park/`` and ``ais_solent/``);
2. ``<dir>/../shared/data`` (a ``shared/data`` folder beside ``<dir>``) for the current directory
   and each of its parents;
3. the same walk from this file's location (a source checkout run with ``PYTHONPATH``).
"""

from __future__ import annotations

import os
from pathlib import Path


def data_root() -> Path:
    """The shared data folder; a path that may not exist when nothing was found."""
    env = os.environ.get('TRACK_DATA_DIR')
    if env:
        return Path(env)
    for start in (Path.cwd(), Path(__file__).resolve().parent):
        for d in (start, *start.parents):
            cand = d.parent / 'shared' / 'data'
            if cand.is_dir():
                return cand
    return Path.cwd().parent / 'shared' / 'data'


def data_dir(name: str) -> Path:
    """``data_root() / name``, e.g. ``data_dir('victoria_park')``."""
    return data_root() / name
