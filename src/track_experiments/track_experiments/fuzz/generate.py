"""Seeded malformed messages, made by mutating a valid template of the topic's type.

Every class of badness has a name (``Bad.kind``), so a report can say which ones a node refuses.
The classes a template gets depend on what it has (its type's fields, not a list per type):
- every float field (scalars and fixed arrays, one field per message, cycling over all of them):
  ``float.nan``, ``float.inf``, ``float.-inf``, ``float.1e308``, ``float.1e30``, ``float.denormal``
  (5e-324); and every float field at once: ``floats.1e308``, ``floats.1e30``, ``floats.denormal``;
- every ``covariance`` field: ``cov.zero``, ``cov.negative``, ``cov.asymmetric``, ``cov.non_psd``,
  ``cov.denormal``, ``cov.huge``;
- every variable-length array: ``array.empty``, ``array.oversized``;
- a ``header``: ``stamp.zero``, ``stamp.future`` (sec = 2147483647), ``stamp.backwards`` (an hour
  before the template), ``frame.wrong``, ``frame.empty``; ``child_frame_id``: ``frame.child_wrong``;
- PointCloud2: ``cloud.point_step``, ``cloud.point_step_zero``, ``cloud.row_step``,
  ``cloud.field_missing`` (the n-th message drops field n mod k), ``cloud.no_fields``,
  ``cloud.truncated``, ``cloud.width_huge``, ``cloud.datatype``, ``cloud.offset``, ``cloud.nan_data``,
  ``cloud.inf_data``;
- DiagnosticArray values: ``value.nan``, ``value.inf``, ``value.1e308``, ``value.denormal``,
  ``value.garbage``, ``value.key_missing``; a ``seq`` or ``step`` key: ``seq.max_i32``,
  ``seq.max_u32``, ``seq.ahead``, ``seq.behind``, ``seq.negative``;
- UInt8MultiArray: ``payload.random``, ``payload.truncated``; the IDSQ protocol (``track_msgs``
  IdsqHandoff, IdsqAck, IdsqRevoke; prefix ``handoff``, ``ack``, ``revoke``):
  ``<prefix>.step_max`` (0xFFFFFFFF), ``<prefix>.step_ahead``, ``<prefix>.step_behind``,
  ``<prefix>.receiver``; a handoff also ``handoff.version`` (unknown), ``handoff.lengths`` (one mass
  fewer than cells), ``handoff.foreign`` (a velocity in a version-1 package);
- a typed protocol message with a ``seq`` (RFID command, step, found, status): ``seq.max_u32``,
  ``seq.ahead``, ``seq.behind``, ``seq.zero``; with a ``kind``: ``kind.unknown``;
- any type: ``duplicate`` (the template again), ``raw.random`` (random bytes after a CDR header,
  published raw), ``raw.truncated`` (the template's CDR cut short).
The generator is pure (no node, no publishing): ``Fuzzer(templates, seed).next()`` → ``Bad``.
"""

from __future__ import annotations

import array
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from rclpy.serialization import serialize_message

from track_experiments.fuzz.fields import (
    Path,
    bad_covariance,
    copy_msg,
    cov_paths,
    field_of,
    float_paths,
    is_msg,
    sequence_paths,
    set_field,
)

BAD_FLOATS = {'nan': math.nan, 'inf': math.inf, '-inf': -math.inf, '1e308': 1e308, '1e30': 1e30,
              'denormal': 5e-324}
ALL_FLOATS = ('1e308', '1e30', 'denormal')
FUTURE_SEC = 2147483647
OVERSIZED = 100_000  # elements of an oversized primitive array (messages: OVERSIZED // 100)
CDR_HEADER = b'\x00\x01\x00\x00'
IDSQ_PREFIX = {'IdsqHandoff': 'handoff', 'IdsqAck': 'ack', 'IdsqRevoke': 'revoke'}  # kinds of the IDSQ protocol



@dataclass
class Bad:
    topic: str
    kind: str
    msg: Any  # a message of the topic's type, or bytes (serialized CDR, published raw)


class Fuzzer:
    """Bad messages for ``templates`` (topic → a valid message), cycling over (topic, kind) pairs."""

    def __init__(self, templates: dict[str, Any], seed: int = 0) -> None:
        self.templates = templates
        self.rng = np.random.default_rng(seed)
        self.count: dict[tuple[str, str], int] = {}
        self.plan = [(topic, kind, fn) for topic, msg in sorted(templates.items()) for kind, fn in self._kinds(msg)]
        self._i = 0

    def kinds(self) -> list[str]:
        return sorted({kind for _, kind, _ in self.plan})

    def next(self) -> Bad:
        topic, kind, fn = self.plan[self._i % len(self.plan)]
        self._i += 1
        n = self.count[(topic, kind)] = self.count.get((topic, kind), 0) + 1
        return Bad(topic, kind, fn(copy_msg(self.templates[topic]), n))

    # -- the classes ---------------------------------------------------------------------------
    def _kinds(self, tpl) -> list[tuple[str, Callable[[Any, int], Any]]]:
        out: list[tuple[str, Callable]] = []
        floats = float_paths(tpl)
        if floats:
            for name, value in BAD_FLOATS.items():
                out.append((f'float.{name}', self._one_float(floats, value)))
            for name in ALL_FLOATS:
                out.append((f'floats.{name}', self._all_floats(floats, BAD_FLOATS[name])))
        for path in cov_paths(tpl):
            n = len(field_of(tpl, path))
            for kind in ('zero', 'negative', 'asymmetric', 'non_psd', 'denormal', 'huge'):
                out.append((f'cov.{kind}', self._setter(path, bad_covariance(kind, n, self.rng))))
        seqs = sequence_paths(tpl)
        if seqs:
            out += [('array.empty', self._sequence(seqs, empty=True)),
                    ('array.oversized', self._sequence(seqs, empty=False))]
        if hasattr(tpl, 'header'):
            out += [('stamp.zero', self._stamp(lambda s: (0, 0))),
                    ('stamp.future', self._stamp(lambda s: (FUTURE_SEC, 0))),
                    ('stamp.backwards', self._stamp(lambda s: (max(1, s.sec - 3600), s.nanosec))),
                    ('frame.wrong', self._setter(('header', 'frame_id'), 'no_such_frame')),
                    ('frame.empty', self._setter(('header', 'frame_id'), ''))]
        if hasattr(tpl, 'child_frame_id'):
            out.append(('frame.child_wrong', self._setter(('child_frame_id',), 'no_such_child#x')))
        type_name = type(tpl).__name__
        if type_name == 'PointCloud2':
            out += self._cloud_kinds()
        if type_name == 'DiagnosticArray':
            out += self._diag_kinds(tpl)
        if type_name == 'UInt8MultiArray':
            out += self._payload_kinds()
        out += self._idsq_kinds(IDSQ_PREFIX[type_name]) if type_name in IDSQ_PREFIX else _counter_kinds(tpl)
        out += [('duplicate', lambda m, n: m),
                ('raw.random', lambda m, n: CDR_HEADER + self.rng.bytes(int(self.rng.integers(0, 256)))),
                ('raw.truncated', _truncated_cdr)]
        return out

    def _setter(self, path: Path, value) -> Callable:
        def fn(m, n):
            set_field(m, path, value)
            return m
        return fn

    def _one_float(self, paths: list[Path], value: float) -> Callable:
        def fn(m, n):
            set_field(m, paths[(n - 1) % len(paths)], value)
            return m
        return fn

    def _all_floats(self, paths: list[Path], value: float) -> Callable:
        def fn(m, n):
            for p in paths:
                set_field(m, p, value)
            return m
        return fn

    def _sequence(self, paths: list[Path], empty: bool) -> Callable:
        def fn(m, n):
            path = paths[(n - 1) % len(paths)]
            cur = field_of(m, path)
            if empty:
                value = type(cur)() if not isinstance(cur, array.array) else array.array(cur.typecode)
            elif isinstance(cur, array.array):
                value = array.array(cur.typecode, self.rng.integers(0, 256, OVERSIZED).astype(np.uint8).tobytes()
                                    if cur.typecode == 'B' else [0] * OVERSIZED)
            elif isinstance(cur, list) and cur and is_msg(cur[0]):
                value = [copy_msg(cur[i % len(cur)]) for i in range(OVERSIZED // 100)]
            elif isinstance(cur, str):
                value = 'x' * OVERSIZED
            else:
                return m  # an empty list of messages: nothing to repeat
            set_field(m, path, value)
            return m
        return fn

    def _stamp(self, new: Callable[[Any], tuple[int, int]]) -> Callable:
        def fn(m, n):
            m.header.stamp.sec, m.header.stamp.nanosec = new(m.header.stamp)
            return m
        return fn

    def _cloud_kinds(self) -> list[tuple[str, Callable]]:
        def edit(change):
            def fn(m, n):
                change(m)
                return m
            return fn

        def drop_one(m, n):
            fields = list(m.fields)
            if fields:
                del fields[(n - 1) % len(fields)]
            m.fields = fields
            return m

        def fill(pattern: bytes):
            def change(m):
                m.data = array.array('B', (pattern * (len(m.data) // len(pattern) + 1))[:len(m.data)])
            return change

        def set_attr(name, value_of):
            return lambda m: setattr(m, name, value_of(m))

        def datatype(m):
            if m.fields:
                m.fields[0].datatype = 99

        def offset(m):
            if m.fields:
                m.fields[-1].offset = m.point_step

        return [('cloud.point_step', edit(set_attr('point_step', lambda m: m.point_step + 1))),
                ('cloud.point_step_zero', edit(set_attr('point_step', lambda m: 0))),
                ('cloud.row_step', edit(set_attr('row_step', lambda m: m.row_step + 3))),
                ('cloud.field_missing', drop_one),
                ('cloud.no_fields', edit(set_attr('fields', lambda m: []))),
                ('cloud.truncated', edit(set_attr('data', lambda m: m.data[:len(m.data) // 2 + 1]))),
                ('cloud.width_huge', edit(set_attr('width', lambda m: 2**31))),
                ('cloud.datatype', edit(datatype)),
                ('cloud.offset', edit(offset)),
                ('cloud.nan_data', edit(fill(b'\xff'))),
                ('cloud.inf_data', edit(fill(b'\x00\x00\x80\x7f')))]

    def _diag_kinds(self, tpl) -> list[tuple[str, Callable]]:
        slots = [(i, j) for i, st in enumerate(tpl.status) for j, _ in enumerate(st.values)]
        numeric = [(i, j) for i, j in slots if _number(tpl.status[i].values[j].value) is not None]
        counters = [(i, j) for i, j in numeric if tpl.status[i].values[j].key in ('seq', 'step')]

        def value_setter(targets, value_of):
            def fn(m, n):
                i, j = targets[(n - 1) % len(targets)]
                kv = m.status[i].values[j]
                kv.value = value_of(kv.value)
                return m
            return fn

        def key_missing(m, n):
            i, j = slots[(n - 1) % len(slots)]
            del m.status[i].values[j]
            return m

        out: list[tuple[str, Callable]] = []
        if numeric:
            for name, text in (('nan', 'nan'), ('inf', 'inf'), ('1e308', '1e308'), ('denormal', '5e-324'),
                               ('garbage', '\x00garbage\xff')):
                out.append((f'value.{name}', value_setter(numeric, lambda v, t=text: t)))
        if slots:
            out.append(('value.key_missing', key_missing))
        if counters:
            def shift(d):
                return lambda v: str(int(float(v)) + d)
            out += [('seq.max_i32', value_setter(counters, lambda v: str(2**31 - 1))),
                    ('seq.max_u32', value_setter(counters, lambda v: str(2**32 - 1))),
                    ('seq.ahead', value_setter(counters, shift(1000))),
                    ('seq.behind', value_setter(counters, shift(-1000))),
                    ('seq.negative', value_setter(counters, lambda v: '-1'))]
        return out

    def _payload_kinds(self) -> list[tuple[str, Callable]]:
        return [('payload.random', self._payload(lambda b: self.rng.bytes(len(b)))),
                ('payload.truncated', self._payload(lambda b: b[:len(b) // 2]))]

    def _payload(self, change: Callable[[bytes], bytes]) -> Callable:
        def fn(m, n):
            m.data = array.array('B', change(bytes(m.data)))
            return m
        return fn

    def _idsq_kinds(self, prefix: str) -> list[tuple[str, Callable]]:
        def edit(change):
            def fn(m, n):
                change(m)
                return m
            return fn

        def set_step(value_of):
            return edit(lambda m: setattr(m, 'step', value_of(m.step)))

        out = [(f'{prefix}.step_max', set_step(lambda s: 0xFFFFFFFF)),
               (f'{prefix}.step_ahead', set_step(lambda s: min(s + 1000, 0xFFFFFFFF))),
               (f'{prefix}.step_behind', set_step(lambda s: max(0, s - 1000))),
               (f'{prefix}.receiver', edit(lambda m: setattr(m, 'receiver', (m.receiver + 7) % 65536)))]
        if prefix == 'handoff':
            out += [('handoff.version', edit(lambda m: setattr(m, 'version', 9))),
                    ('handoff.lengths', edit(lambda m: setattr(m, 'mass', m.mass[:-1]))),
                    ('handoff.foreign', edit(lambda m: (setattr(m, 'version', 1), setattr(m, 'velocity_x', 3.0))))]
        return out


def _counter_kinds(tpl) -> list[tuple[str, Callable]]:
    """A typed protocol message's ``seq`` (uint32) and ``kind`` (uint8) fields: out-of-window and unknown values."""
    def set_field(name, value_of):
        def fn(m, n):
            setattr(m, name, value_of(getattr(m, name)))
            return m
        return fn

    out = []
    if isinstance(getattr(tpl, 'seq', None), int) and not isinstance(tpl.seq, bool):
        out += [('seq.max_u32', set_field('seq', lambda v: 0xFFFFFFFF)),
                ('seq.ahead', set_field('seq', lambda v: min(v + 1000, 0xFFFFFFFF))),
                ('seq.behind', set_field('seq', lambda v: max(0, v - 1000))),
                ('seq.zero', set_field('seq', lambda v: 0))]
    if isinstance(getattr(tpl, 'kind', None), int):
        out.append(('kind.unknown', set_field('kind', lambda v: 200)))
    return out


def _truncated_cdr(m, n) -> bytes:
    b = serialize_message(m)
    return b[:max(4, len(b) // 2)]


def _number(text: str) -> float | None:
    try:
        return float(text)
    except ValueError:
        return None
