"""``--help`` of a node executable: what the node does, how to run it, every parameter with its default.

Asked before ``--ros-args`` (``ros2 run track_nodes fusion --help``), it prints and exits 0 without
rclpy or DDS: nothing joins the graph. The parameter list is the one the node declares
(``base/params.all_specs``), so ``ros2 param describe`` on a running node says the same.

The text needs the node's class, whose module imports rclpy, numpy and the core: seconds on an idle
machine, over 15 s on a loaded one, for a page of text. So ``python -m track_nodes EXE --help`` (what
the ``ros2 run`` shims call) keeps every text it printed in a cache (``help_cache_dir``: one JSON file
per state of the sources) and answers from it without importing any of that: this module, the
registry and ``track_nodes/__main__.py`` import only the standard library. The cache's name is a
fingerprint of every source file of ``track_nodes``, ``track_core`` and ``track_msgs_py`` (path,
size, modification time), so an edited, reinstalled or upgraded package never answers with an old
text; a cache that cannot be written (read-only home) only costs the import.
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib.util
import json
import os
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path

HELP_FLAGS = ('-h', '--help')
CACHE_ENV = 'TRACK_NODES_CACHE'  # a directory for the help cache (default: $XDG_CACHE_HOME/track_nodes)
SOURCES = ('track_nodes', 'track_core', 'track_msgs_py')  # what a help text is made of


def wants_help(args: Sequence[str]) -> bool:
    """True when ``-h``/``--help`` comes before ``--ros-args`` (after it, the words are rcl's)."""
    args = list(args)
    own = args[:args.index('--ros-args')] if '--ros-args' in args else args
    return any(a in HELP_FLAGS for a in own[1:])


def usage(executable: str, cls: type) -> str:
    """The help text of the node class ``cls`` run as ``executable``."""
    from track_nodes.base.params import all_specs

    doc = (cls.__doc__ or '').strip() or (sys.modules[cls.__module__].__doc__ or '').strip()
    doc = doc.split('\n\n')[0]
    lines = [f'usage: ros2 run track_nodes {executable} [--ros-args [-r __node:=NAME] [-r __ns:=/NS] '
             '[-p NAME:=VALUE] [--params-file FILE]]',
             f'   or: python -m track_nodes {executable} [--ros-args ...]', '',
             ' '.join(doc.split()), '',
             f'node name: {cls.DEFAULT_NAME} (by default)']
    specs = all_specs(cls.Params)
    if not specs:
        lines.append('parameters: none of its own (use_sim_time and the ROS ones)')
        return '\n'.join(lines)
    lines.append('parameters (name = default; allowed; live: settable with ros2 param set):')
    for s in specs:
        bounded = s.choices is not None or s.lo is not None or s.hi is not None
        allowed = s.allowed() if bounded else type(s.default).__name__
        lines.append(f"  {s.name} = {s.default!r}  ({allowed}; {'live' if s.live else 'read-only'})  {s.description}")
    return '\n'.join(lines)


# -- the cache ---------------------------------------------------------------------------------------
def help_cache_dir() -> Path:
    if os.environ.get(CACHE_ENV):
        return Path(os.environ[CACHE_ENV])
    return Path(os.environ.get('XDG_CACHE_HOME') or Path.home() / '.cache') / 'track_nodes'


def _package_dir(name: str) -> Path | None:
    """Where the top-level package ``name`` is, found without running it (``find_spec`` of a top-level name)."""
    spec = importlib.util.find_spec(name)
    locations = list(spec.submodule_search_locations or []) if spec is not None else []
    return Path(locations[0]) if locations else None


def fingerprint() -> str:
    """A name for the current state of the sources a help text is made of (and of the interpreter)."""
    h = hashlib.sha1(sys.version.encode())
    for name in SOURCES:
        root = _package_dir(name)
        h.update(str(root).encode())
        if root is None:
            continue
        for dirpath, dirnames, filenames in os.walk(root):
            dirnames[:] = sorted(d for d in dirnames if d != '__pycache__')
            for f in sorted(filenames):
                if f.endswith('.py'):
                    st = os.stat(os.path.join(dirpath, f))
                    h.update(f'{dirpath}/{f}:{st.st_size}:{st.st_mtime_ns}\n'.encode())
    return h.hexdigest()[:20]


def _cache_file() -> Path:
    return help_cache_dir() / f'help-{fingerprint()}.json'


def cached_help(args: Sequence[str]) -> str | None:
    """The text ``args`` (``[executable, '--help']``) printed before with these sources, or None."""
    key = ' '.join(args)
    with contextlib.suppress(OSError, ValueError):
        return json.loads(_cache_file().read_text()).get(key)
    return None


def remember_help(args: Sequence[str], text: str) -> None:
    """Keep ``text`` as the help of ``args`` (atomically: a concurrent ``--help`` reads an old or a new file)."""
    with contextlib.suppress(OSError, ValueError):
        path = _cache_file()
        path.parent.mkdir(parents=True, exist_ok=True)
        try:
            texts = json.loads(path.read_text())
        except (OSError, ValueError):
            texts = {}
        texts[' '.join(args)] = text
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix='.help-')
        with os.fdopen(fd, 'w') as f:
            json.dump(texts, f)
        os.replace(tmp, path)
        for old in path.parent.glob('help-*.json'):  # the texts of other states of the sources
            if old != path:
                with contextlib.suppress(OSError):
                    old.unlink()
