"""Walking a ROS message's fields by path: the float fields, the sequences, the covariances (for the fuzzer)."""

from __future__ import annotations

import array
import math
from collections.abc import Iterator
from typing import Any

import numpy as np
from rclpy.serialization import deserialize_message, serialize_message

Path = tuple[Any, ...]


def copy_msg(msg):
    return deserialize_message(serialize_message(msg), type(msg))


def is_msg(value) -> bool:
    return hasattr(type(value), 'get_fields_and_field_types')


def float_paths(msg, prefix: Path = ()) -> list[Path]:
    """Every float leaf of ``msg`` (array elements included) as an attribute/index path."""
    out: list[Path] = []
    for name in type(msg).get_fields_and_field_types():
        value = getattr(msg, name)
        path = (*prefix, name)
        if isinstance(value, float):
            out.append(path)
        elif isinstance(value, np.ndarray) and value.dtype.kind == 'f':
            out += [(*path, i) for i in range(value.size)]
        elif isinstance(value, array.array) and value.typecode in 'fd':
            out += [(*path, i) for i in range(len(value))]
        elif is_msg(value):
            out += float_paths(value, path)
        elif isinstance(value, list):
            for i, item in enumerate(value):
                if is_msg(item):
                    out += float_paths(item, (*path, i))
    return out


def sequence_paths(msg, prefix: Path = ()) -> list[Path]:
    """Every variable-length array field (``sequence<...>``) of ``msg``, nested ones included."""
    out: list[Path] = []
    for name, typ in type(msg).get_fields_and_field_types().items():
        value = getattr(msg, name)
        path = (*prefix, name)
        if typ.startswith('sequence<'):
            out.append(path)
        if is_msg(value):
            out += sequence_paths(value, path)
        elif isinstance(value, list):
            for i, item in enumerate(value):
                if is_msg(item):
                    out += sequence_paths(item, (*path, i))
    return out


def field_of(msg, path: Path):
    for step in path:
        msg = msg[step] if isinstance(step, int) else getattr(msg, step)
    return msg


def set_field(msg, path: Path, value) -> None:
    parent = field_of(msg, path[:-1])
    if isinstance(path[-1], int):
        parent[path[-1]] = value
    else:
        setattr(parent, path[-1], value)


def cov_paths(msg) -> list[Path]:
    return [p for p in all_fields(msg) if p[-1] == 'covariance']


def all_fields(msg, prefix: Path = ()) -> Iterator[Path]:
    for name in type(msg).get_fields_and_field_types():
        value = getattr(msg, name)
        yield (*prefix, name)
        if is_msg(value):
            yield from all_fields(value, (*prefix, name))


def bad_covariance(kind: str, n: int, rng: np.random.Generator) -> np.ndarray:
    k = math.isqrt(n)
    if kind == 'zero':
        m = np.zeros((k, k))
    elif kind == 'negative':
        m = -np.eye(k)
    elif kind == 'asymmetric':
        m = np.eye(k)
        m[0, 1] = 0.5
    elif kind == 'non_psd':
        m = np.eye(k)
        m[0, 1] = m[1, 0] = 3.0
    elif kind == 'denormal':
        m = np.eye(k) * 5e-324
    else:  # huge
        m = np.eye(k) * 1e300
    return m.reshape(-1)


def nonfinite(msg) -> str | None:
    """The first NaN/inf in ``msg``'s floats, PointCloud2 float fields or numeric diagnostic values."""
    for path in float_paths(msg):
        if not math.isfinite(field_of(msg, path)):
            return '.'.join(map(str, path))
    name = type(msg).__name__
    if name == 'PointCloud2':
        bad = _cloud_nonfinite(msg)
        if bad:
            return bad
    if name == 'DiagnosticArray':
        for st in msg.status:
            for kv in st.values:
                try:
                    v = float(kv.value)
                except ValueError:
                    continue
                if not math.isfinite(v):
                    return f'{st.name}/{kv.key}={kv.value}'
    return None


def _cloud_nonfinite(msg) -> str | None:
    data = bytes(msg.data)
    step, n = msg.point_step, msg.width * msg.height
    if step == 0 or n == 0 or len(data) < step * n:
        return None
    for f in msg.fields:
        code = {7: 'f4', 8: 'f8'}.get(f.datatype)
        if code is None:
            continue
        dt = np.dtype(('>' if msg.is_bigendian else '<') + code)
        if f.offset + dt.itemsize > step:
            continue
        vals = np.ndarray((n,), dtype=dt, buffer=data, offset=f.offset, strides=(step,))
        if not np.all(np.isfinite(vals)):
            return f'data.{f.name}'
    return None
