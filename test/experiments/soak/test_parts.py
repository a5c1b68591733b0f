"""The soak's parts stop every child they started, also when interrupted (Ctrl-C, a test's timeout)."""

from __future__ import annotations

from typing import ClassVar

import pytest

from track_experiments.soak import parts


class _Child:
    """Stands in for ``procs.Proc`` (a child process); the interrupt lands while the part waits on it."""

    made: ClassVar[list] = []

    def __init__(self, *_args, **_kwargs) -> None:
        self.stopped = False
        _Child.made.append(self)

    def wait_for(self, *_args, **_kwargs):
        raise KeyboardInterrupt

    def send_term(self) -> None:
        self.stopped = True

    def terminate(self, *_args) -> int:
        self.stopped = True
        return 0


@pytest.mark.parametrize('part', ['concurrent', 'bringup'])
def test_an_interrupted_part_stops_its_children(monkeypatch, tmp_path, part):
    _Child.made = []
    monkeypatch.setattr(parts, 'Proc', _Child)
    with pytest.raises(KeyboardInterrupt):
        if part == 'concurrent':
            parts.concurrent(tmp_path, {}, run_s=0.0, timeout=1.0)
        else:
            parts.bringup(tmp_path, {}, sensors=8, run_s=0.0, timeout=1.0)
    assert _Child.made and all(c.stopped for c in _Child.made)
