"""The figures of a long run: each process's memory against data time, and the outputs' pace.

Memory is the resident set (``VmRSS``) of the launcher and of every process it started, read
from /proc; its growth is the least-squares slope against data time after a warm-up (the first
``WARMUP_SHARE`` of the run: queues, caches and the allocator's arenas fill first, then stay).
The pace is compared between the first and the last quarter of data time: outputs whose stamps
fall in a quarter per wall second that quarter took (``probe``), so a run that slows down, or
whose outputs thin out, shows it whatever the machine's absolute speed.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

WARMUP_SHARE = 0.25  # the first quarter of data time is not part of the slope (it is the pace's baseline)
HOUR = 3600.0
MIB = 1024.0  # kB per MiB (VmRSS is in kB)


@dataclass
class Series:
    """One process's samples: (data s, RSS MiB, CPU s)."""

    label: str
    samples: list[tuple[float, float, float]] = field(default_factory=list)

    def slope(self, warmup_s: float) -> float | None:
        """RSS growth [MiB per data hour] after ``warmup_s`` (least squares; None with < 3 samples)."""
        pts = np.array([(t, r) for t, r, _ in self.samples if t >= warmup_s])
        if len(pts) < 3 or np.ptp(pts[:, 0]) <= 0:
            return None
        return float(np.polyfit(pts[:, 0] / HOUR, pts[:, 1], 1)[0])


def children(pid: int) -> list[int]:
    """The processes ``pid`` started (Linux /proc/PID/task/*/children)."""
    found: list[int] = []
    for task in Path(f'/proc/{pid}/task').glob('*'):
        try:
            found += [int(c) for c in (task / 'children').read_text().split()]
        except OSError:
            continue
    return found


def label_of(pid: int) -> str:
    """A child's node name (``__node:=NAME``), ``recorder``, or its pid."""
    try:
        args = Path(f'/proc/{pid}/cmdline').read_bytes().decode(errors='replace').split('\0')
    except OSError:
        return str(pid)
    for a in args:
        if a.startswith('__node:='):
            return a.split(':=', 1)[1]
    return 'recorder' if 'recorder' in args else str(pid)


def rss_cpu(pid: int) -> tuple[float, float] | None:
    """(RSS MiB, CPU s of every thread) of ``pid``; None once it is gone."""
    try:
        status = Path(f'/proc/{pid}/status').read_text()
        stat = Path(f'/proc/{pid}/stat').read_text().rsplit(')', 1)[1].split()
    except OSError:
        return None
    rss = next((int(ln.split()[1]) for ln in status.splitlines() if ln.startswith('VmRSS:')), None)
    if rss is None:  # a zombie has no VmRSS
        return None
    return rss / MIB, (float(stat[11]) + float(stat[12])) / os.sysconf('SC_CLK_TCK')


def sample(root: int, data_s: float, series: dict[int, Series], root_label: str) -> None:
    """One sample of ``root`` and its children at data time ``data_s``, appended to ``series`` (by pid)."""
    for pid in [root, *children(root)]:
        got = rss_cpu(pid)
        if got is None:
            continue
        if pid not in series:
            series[pid] = Series(root_label if pid == root else label_of(pid))
        series[pid].samples.append((data_s, *got))


def quarters(clock: list[tuple[float, int]], outputs: dict[str, list[tuple[float, int]]], epoch_ns: int | None,
             duration: float) -> list[dict]:
    """Per quarter of data time: its wall seconds, the data pace and the outputs per wall second."""
    if epoch_ns is None or not clock:
        return []
    walls = np.array([w for w, _ in clock])
    secs = np.array([s for _, s in clock], dtype=float)
    edges = [duration * q / 4 for q in range(5)]
    rows = []
    for q in range(4):
        lo, hi = edges[q], edges[q + 1]
        if secs[-1] < hi:
            break  # the clock never finished this quarter
        wall = float(walls[np.searchsorted(secs, hi)] - walls[np.searchsorted(secs, lo)])
        counts = {t: sum(1 for _, s in v if lo <= (s - epoch_ns) / 1e9 < hi) for t, v in outputs.items()}
        total = sum(counts.values())
        rows.append({'quarter': q + 1, 'wall_s': wall, 'pace': (hi - lo) / wall if wall > 0 else None,
                     'outputs': total, 'per_wall_s': total / wall if wall > 0 else None, 'by_topic': counts})
    return rows
