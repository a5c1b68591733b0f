"""Typed records for the layouts that travel inside messages: ``track_msgs`` ones and standard ones.

The protocols and per-tick arrays have their own ``track_msgs`` messages (RFID commands and
steps, the IDSQ handoff, ack, revoke and leader events, fusion pair scores); their records here
convert with ``to_msg``/``from_msg``. A layout still carried in ``diagnostic_msgs/DiagnosticStatus``
key/values (a mode, a target status, the AIS truth table) has one typed record here, a frozen
dataclass derived from ``StatusRecord``, read and written only through it:
``record.to_values()`` / ``Record.from_values(mapping)`` (the key/value strings),
``record.to_status(name, level, message)`` / ``Record.from_status(status)``. Each field's
annotation says how it is written (and parsed back):

| annotation | written as | parsed by |
|---|---|---|
| ``str`` | itself | itself |
| ``int`` | ``str(int)`` | ``int`` |
| ``float`` | ``str(float)`` (shortest repr: round-trips exactly) | ``float`` |
| ``bool`` | ``true`` / ``false`` | the same two words |
| ``tuple[int, ...]`` / ``tuple[float, ...]`` | items joined by one space | split on whitespace |
| ``X | None`` | ``None`` is an absent key | absent key → ``None`` |

``field(metadata={'key': 'name'})`` renames the key; ``{'fmt': callable}`` formats a value (or
each item of a tuple) differently on the way out (for example ``'{:.6g}'.format``). A key
that is missing or does not parse raises ``RecordError`` naming the record, the key and the
value, so a node can refuse the message with that one line.

A layout carried in ``sensor_msgs/PointCloud2`` fields is a record too (a frozen dataclass of
arrays with ``to_msg``/``from_msg``: ``slam.SlamScan``, ``rfid.RfidPhase``, ``idsq.IdsqBelief``).
Every one we publish starts with float32 x, y, z (``clouds.points_to_pointcloud2``);
``read_cloud`` reads one back with the same one-line ``RecordError``.
"""

from __future__ import annotations

import dataclasses
import math
import types
import typing
from collections.abc import Mapping
from functools import cache
from typing import Any, ClassVar, Self

import numpy as np
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue

from track_msgs_py.clouds import pointcloud2_to_table
from track_msgs_py.diagnostics import DIAG_ERROR as DIAG_ERROR  # the levels, re-exported for the records
from track_msgs_py.diagnostics import DIAG_OK, DIAG_STALE
from track_msgs_py.diagnostics import DIAG_WARN as DIAG_WARN


class RecordError(ValueError):
    """A message does not hold a valid record; the text is one line naming the key."""


def finite_value(record: str, name: str, value: float) -> float:
    """``value`` as a float, or ``RecordError`` naming the record and the field when it is not finite."""
    value = float(value)
    if not math.isfinite(value):
        raise RecordError(f'{record}: non-finite {name}={value}')
    return value


def read_cloud(kind: str, msg, required: tuple[str, ...]) -> dict[str, np.ndarray]:
    """The columns of a ``PointCloud2`` (``clouds.pointcloud2_to_table``), x, y, z included; ``RecordError``
    naming ``kind`` when the cloud does not decode or a ``required`` field is missing or has count > 1."""
    try:
        table = pointcloud2_to_table(msg)
    except ValueError as exc:
        raise RecordError(f'{kind}: {exc}') from None
    missing = [k for k in required if k not in table]
    if missing:
        raise RecordError(f'{kind}: needs float fields {", ".join(required)}, missing {", ".join(missing)} '
                          f'(fields: {", ".join(table) or "none"})')
    if any(table[k].ndim != 1 for k in required):
        raise RecordError(f'{kind}: {", ".join(required)} must have count 1')
    return table


def diagnostic_values(status: DiagnosticStatus) -> dict[str, str]:
    """The key/values of one ``DiagnosticStatus`` as a dict (the one place this is read by hand)."""
    return {kv.key: kv.value for kv in status.values}


def _optional(tp: Any) -> tuple[Any, bool]:
    args = typing.get_args(tp)
    if typing.get_origin(tp) in (typing.Union, types.UnionType) and type(None) in args:
        rest = [a for a in args if a is not type(None)]
        return rest[0], True
    return tp, False


def _write(tp: Any, value: Any, fmt) -> str:
    if typing.get_origin(tp) is tuple:
        item = typing.get_args(tp)[0]
        return ' '.join(_write(item, v, fmt) for v in value)
    if fmt is not None:
        return fmt(value)
    if tp is bool:
        return 'true' if value else 'false'
    if tp is float:
        return str(float(value))
    if tp is int:
        return str(int(value))
    return str(value)


def _read(tp: Any, text: str) -> Any:
    if typing.get_origin(tp) is tuple:
        item = typing.get_args(tp)[0]
        return tuple(_read(item, t) for t in text.split())
    if tp is bool:
        if text not in ('true', 'false'):
            raise ValueError(f'expected true or false, got {text!r}')
        return text == 'true'
    if tp is int:
        return int(text)
    if tp is float:
        return float(text)
    return text


@cache
def _fields(cls: type) -> tuple[tuple[str, str, Any, bool, Any, bool], ...]:
    """(attribute, key, type, optional, fmt, has_default) per field of ``cls``."""
    hints = typing.get_type_hints(cls)
    out = []
    for f in dataclasses.fields(cls):
        if not f.init:
            continue
        tp, opt = _optional(hints[f.name])
        has_default = f.default is not dataclasses.MISSING or f.default_factory is not dataclasses.MISSING
        out.append((f.name, f.metadata.get('key', f.name), tp, opt, f.metadata.get('fmt'), has_default))
    return tuple(out)


class StatusRecord:
    """Base of the frozen dataclasses carried as the key/values of one ``DiagnosticStatus``."""

    KIND: ClassVar[str] = 'record'  # used in error messages

    def to_values(self) -> dict[str, str]:
        out = {}
        for attr, key, tp, _, fmt, _ in _fields(type(self)):
            value = getattr(self, attr)
            if value is not None:
                out[key] = _write(tp, value, fmt)
        return out

    @classmethod
    def from_values(cls, values: Mapping[str, str]) -> Self:
        kw = {}
        for attr, key, tp, opt, _, has_default in _fields(cls):
            if key not in values:
                if opt:
                    kw[attr] = None
                elif not has_default:
                    raise RecordError(f'{cls.KIND}: missing key {key!r}')
                continue
            try:
                kw[attr] = _read(tp, values[key])
            except ValueError as exc:
                raise RecordError(f'{cls.KIND}: key {key}={values[key]!r} is invalid ({exc})') from None
        try:
            return cls(**kw)
        except (TypeError, ValueError) as exc:
            raise RecordError(f'{cls.KIND}: {exc}') from None

    @classmethod
    def from_status(cls, status: DiagnosticStatus) -> Self:
        return cls.from_values(diagnostic_values(status))

    def to_status(self, name: str, level: int = DIAG_OK, message: str = '', hardware_id: str = '',
                  extra: Mapping[str, object] | None = None) -> DiagnosticStatus:
        """One ``DiagnosticStatus`` holding this record (``extra``: key/values appended as ``str``)."""
        if not DIAG_OK <= int(level) <= DIAG_STALE:
            raise ValueError(f'diagnostic level must be 0..3 (OK, WARN, ERROR, STALE), got {level!r}')
        values = [KeyValue(key=k, value=v) for k, v in self.to_values().items()]
        values += [KeyValue(key=str(k), value=str(v)) for k, v in (extra or {}).items()]
        return DiagnosticStatus(level=bytes([int(level)]), name=name, message=message, hardware_id=hardware_id,
                                values=values)
