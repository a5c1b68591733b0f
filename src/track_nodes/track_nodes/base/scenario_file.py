"""A scenario file's node sections, read without the launcher.

Scenario files are ROS params files whose sections name one node each (``/**/name:``, the form our
files use so that they apply in any namespace; ``/name:`` and ``name:`` work too). The reports that
rebuild a run from its scenario (``report.maritime_sim``, ``report.network_replay``) read them here,
so nothing below the launcher imports it.
"""

from __future__ import annotations

from typing import Any


def section_node(key: str) -> str:
    """The node name a top-level section key names (``/**/sensor_3`` → ``sensor_3``)."""
    return str(key).rsplit('/', 1)[-1]


def node_params(doc: Any, name: str) -> dict[str, Any]:
    """The ``ros__parameters`` a params document gives node ``name`` in its own section (``name:``,
    ``/name:`` or ``/**/name:``); KeyError when it has none."""
    for key in (f'/**/{name}', f'/{name}', name):
        if isinstance(doc.get(key), dict) and 'ros__parameters' in doc[key]:
            return doc[key]['ros__parameters']
    raise KeyError(f'no section for node {name!r}')
