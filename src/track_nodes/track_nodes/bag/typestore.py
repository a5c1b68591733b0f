"""The rosbags type store of the bag tools: the Jazzy standard types plus our interface packages.

Why: rosbags ships the standard types only, so a recorder or checker built on it could neither
write the schema of a ``track_msgs`` topic nor decode it. The definitions are read from the
installed ``.msg`` files (``share/<pkg>/msg``, the text the messages were generated from), so a
new message needs no edit here. The share directory is found beside the package's Python module
(the same install prefix: the venv, a colcon install, /opt/ros), so it needs no ``AMENT_PREFIX_PATH``.
"""

from __future__ import annotations

import importlib.util
from functools import cache
from pathlib import Path

from rosbags.typesys import Stores, get_types_from_msg, get_typestore

#: Interface packages built by tools/build_interfaces.py whose types rosbags does not ship.
OUR_PACKAGES = ('track_msgs',)


def _share(pkg: str) -> Path | None:
    """``<prefix>/share/<pkg>`` of the prefix the package's Python module is installed in."""
    spec = importlib.util.find_spec(pkg)
    if spec is None or spec.origin is None:
        return None
    share = Path(spec.origin).parents[4] / 'share' / pkg  # <prefix>/lib/python3.X/site-packages/<pkg>/__init__.py
    return share if share.is_dir() else None


@cache
def our_types() -> dict:
    """Field definitions of every installed message of ``OUR_PACKAGES`` (a package not installed: none)."""
    types: dict = {}
    for pkg in OUR_PACKAGES:
        share = _share(pkg)
        for path in sorted(share.glob('msg/*.msg')) if share else ():
            types |= get_types_from_msg(path.read_text(encoding='utf-8'), f'{pkg}/msg/{path.stem}')
    return types


def typestore():
    """A fresh Jazzy type store that knows ``our_types()`` too."""
    ts = get_typestore(Stores.ROS2_JAZZY)
    ts.register(our_types())
    return ts
