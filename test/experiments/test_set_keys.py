"""Every ``track-experiment``/``track-bench`` entry declares (``track_experiments.cli.set_keys``) each ``--set`` key
its module reads, so the runner's check of unknown keys never refuses a key that an entry uses."""

from __future__ import annotations

import inspect
import re

import pytest

from track_experiments.cli import entry_keys, registry

READS = re.compile(r"""options(?:\.get\(|\[)\s*['"](\w+)['"]|_option_\w+\(\s*cfg\s*,\s*['"](\w+)['"]""")


@pytest.mark.parametrize('kind', ['experiment', 'bench'])
def test_every_entry_declares_the_set_keys_its_module_reads(kind):
    for name, ep in sorted(registry(kind).items()):
        fn = ep.load()
        read = {a or b for a, b in READS.findall(inspect.getsource(inspect.getmodule(fn)))}
        assert read <= set(entry_keys(fn)), f'{kind} {name}: reads {sorted(read - set(entry_keys(fn)))} undeclared'
