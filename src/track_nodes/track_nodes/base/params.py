"""Node parameters: one typed dataclass per node, declared by the node base.

A node names its parameter dataclass (``TrackNode.Params``); the base declares every field as a
ROS parameter and puts the checked values, as an instance of that dataclass, in ``self.p``:

- ``param(default, description, lo, hi, choices=, live=)``: one field. Its metadata give the
  ParameterDescriptor (``ros2 param describe`` shows the description, the range and whether it is
  live); a value outside the range, of the wrong type or not among ``choices`` raises
  ``ParameterError`` with one line naming the parameter, the value and what is allowed.
  ``default_from(values)`` computes the default from the fields declared before it (the slam
  node's ``profile``).
- ``group(core_dataclass)``: a core configuration dataclass as ``<field>.<name>`` parameters, one per
  number, bool or number-tuple field, with the core's defaults and the core's own checks; the field
  holds the core dataclass. Defaults live once, in the core.
- ``vector``: a list parameter as a finite numpy vector of a fixed length, or one line.
- Names: an override addressed to a node that names no parameter it declares (a typo) is refused
  once the node is built, with the closest declared names (``base/names.py``).

Run time: a field with ``live=True`` (rates, thresholds, gates) may be changed with ``ros2 param
set``; the node base checks the new value like a start value and the node applies it
(``TrackNode.apply_params``). Every other parameter is declared read-only, so ``ros2 param set``
refuses it with a reason instead of answering "successful" and ignoring it.

``ParameterError`` is the one error of a bad parameter, at start or at run time.
"""

from __future__ import annotations

import dataclasses
import math
import sys
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Any

import numpy as np
from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rclpy.exceptions import ParameterException
from rclpy.node import Node


class ParameterError(ValueError):
    """A node parameter has an invalid value; the message is one line."""


@dataclass(frozen=True)
class Param:
    """Declaration of one node parameter. ``lo``/``hi`` are inclusive bounds for numbers."""

    name: str
    default: Any
    description: str
    lo: float | None = None
    hi: float | None = None
    choices: tuple[str, ...] | None = None
    live: bool = False  # may change at run time (validated, then applied by the node); else read-only
    default_from: Callable[[Mapping[str, Any]], Any] | None = None  # default from the fields before it

    def numeric(self) -> bool:
        """A number (int or float, not bool): the only kind a numeric range applies to."""
        return isinstance(self.default, (int, float)) and not isinstance(self.default, bool)

    def allowed(self) -> str:
        """What the parameter accepts, in words: a range only for numbers (``ros2 param describe`` shows it;
        "[-inf, inf]" for a string or a flag read as a numeric parameter)."""
        if self.choices is not None:
            return 'one of ' + ', '.join(self.choices)
        d = self.default
        lo = '-inf' if self.lo is None else f'{self.lo:g}'
        hi = 'inf' if self.hi is None else f'{self.hi:g}'
        if isinstance(d, (list, tuple)):
            kinds = {'true or false' if isinstance(x, bool) else 'strings' if isinstance(x, str) else 'numbers'
                     for x in d}
            kind = kinds.pop() if len(kinds) == 1 else 'numbers'
            bounded = kind == 'numbers' and (self.lo is not None or self.hi is not None)
            return f'a list of {kind}' + (f' in [{lo}, {hi}]' if bounded else '')
        if isinstance(d, bool):
            return 'true or false'
        return 'any string' if isinstance(d, str) else f'[{lo}, {hi}]'

    def descriptor(self) -> ParameterDescriptor:
        when = 'settable at run time' if self.live else 'read-only after start'
        d = ParameterDescriptor(name=self.name, description=f'{self.description} (allowed: {self.allowed()}; {when})',
                                read_only=not self.live)
        if not self.numeric() or (self.lo is None and self.hi is None):
            return d
        lo = -sys.float_info.max if self.lo is None else self.lo
        hi = sys.float_info.max if self.hi is None else self.hi
        if isinstance(self.default, int):
            d.integer_range = [IntegerRange(from_value=int(max(lo, -(2**62))), to_value=int(min(hi, 2**62)), step=0)]
        elif isinstance(self.default, float):
            d.floating_point_range = [FloatingPointRange(from_value=float(lo), to_value=float(hi), step=0.0)]
        return d

    def check(self, value: Any) -> None:
        if self.choices is not None and value not in self.choices:
            raise ParameterError(f'parameter {self.name}={value!r} is invalid: allowed {self.allowed()}')
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            bad_lo = self.lo is not None and not value >= self.lo
            bad_hi = self.hi is not None and not value <= self.hi
            if bad_lo or bad_hi or math.isnan(value):
                raise ParameterError(f'parameter {self.name}={value!r} is out of range: allowed {self.allowed()}')


def declare_params(node: Node, specs: Iterable[Param]) -> SimpleNamespace:
    """Declare ``specs`` on ``node`` and return their checked values as attributes.

    A ``TrackNode`` remembers the specs (``node._specs``), so its run-time checks know them.
    """
    values = {}
    known = getattr(node, '_specs', None)
    for spec in specs:
        if known is not None:
            known[spec.name] = spec
        try:
            param = node.declare_parameter(spec.name, spec.default, spec.descriptor())
        except ParameterException as exc:
            # rclpy's own range/type checks: keep only the first line of its message.
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise ParameterError(f'parameter {spec.name}: {first} (allowed: {spec.allowed()})') from None
        value = param.value
        spec.check(value)
        values[spec.name] = value
    return SimpleNamespace(**values)


def vector(name: str, value: Any, n: int, positive: bool = False) -> np.ndarray:
    """Parameter ``name`` as ``n`` finite (and, with ``positive``, > 0) floats, else ``ParameterError``."""
    v = np.asarray(value, dtype=float)
    if v.shape != (n,) or not np.all(np.isfinite(v)) or (positive and np.any(v <= 0)):
        what = 'positive' if positive else 'finite'
        raise ParameterError(f'parameter {name}={list(value)!r} is invalid: allowed {n} {what} numbers')
    return v


def _plain(v: Any) -> Any:
    """A dataclass field value as a ROS parameter value (tuples → lists of float, numpy → python)."""
    if isinstance(v, (tuple, list, np.ndarray)):
        return [float(x) for x in v]
    if isinstance(v, (bool, np.bool_)):
        return bool(v)
    if isinstance(v, (int, np.integer)):
        return int(v)
    return float(v)


def _scalar_field(v: Any) -> bool:
    if isinstance(v, (tuple, list)):
        return all(isinstance(x, (int, float, np.number)) and not isinstance(x, bool) for x in v)
    return isinstance(v, (bool, int, float, np.number, np.bool_))


def dataclass_params(prefix: str, default: Any) -> list[Param]:
    """One Param per number/bool/number-tuple field of the dataclass instance ``default``, named
    ``<prefix>.<field>`` with the instance's value as default (other fields keep their value)."""
    cls = type(default)
    return [Param(f'{prefix}.{f.name}', _plain(getattr(default, f.name)),
                  f'{cls.__name__}.{f.name} of {cls.__module__} (see its docstring)')
            for f in dataclasses.fields(cls) if _scalar_field(getattr(default, f.name))]


def replace_dataclass(prefix: str, default: Any, values: dict) -> Any:
    """``default`` with the declared values; the core's own checks → ParameterError (one line)."""
    kw = {}
    for f in dataclasses.fields(type(default)):
        key = f'{prefix}.{f.name}'
        if key in values:
            v = values[key]
            kw[f.name] = tuple(v) if isinstance(getattr(default, f.name), tuple) else v
    try:
        return dataclasses.replace(default, **kw)
    except (ValueError, TypeError) as exc:
        raise ParameterError(f'parameter {prefix}.{exc}' if str(exc)[:1].isalpha() else
                             f'parameters {prefix}.*: {exc}') from None


def declare_dataclass(node: Node, prefix: str, default: Any) -> Any:
    """Declare ``default``'s fields as ``<prefix>.*`` parameters and return the dataclass they give."""
    return replace_dataclass(prefix, default, vars(declare_params(node, dataclass_params(prefix, default))))


_PARAM = 'track_nodes.param'
_GROUP = 'track_nodes.group'


def param(default: Any, description: str, lo: float | None = None, hi: float | None = None, *,
          choices: tuple[str, ...] | None = None, live: bool = False,
          default_from: Callable[[Mapping[str, Any]], Any] | None = None) -> Any:
    """A field of a node's parameter dataclass (see the module docstring); a list default is copied."""
    spec = Param('', default, description, lo, hi, choices, live, default_from)
    if isinstance(default, list):
        return dataclasses.field(default_factory=lambda: list(default), metadata={_PARAM: spec})
    return dataclasses.field(default=default, metadata={_PARAM: spec})


def group(default: Callable[[], Any], *, default_from: Callable[[Mapping[str, Any]], Any] | None = None) -> Any:
    """A field holding a core configuration dataclass, declared as ``<field>.<name>`` parameters.

    ``default`` makes the core's default instance (e.g. the dataclass itself); ``default_from(values)``
    makes it from the fields declared before this one instead."""
    return dataclasses.field(default_factory=default, metadata={_GROUP: default_from or (lambda _: default())})


@dataclass
class NoParams:
    """The parameters of a node that has none of its own."""


def param_specs(cls: type) -> list[Param]:
    """The ``Param`` of every ``param`` field of the parameter dataclass ``cls`` (groups left out)."""
    return [dataclasses.replace(f.metadata[_PARAM], name=f.name) for f in dataclasses.fields(cls)
            if _PARAM in f.metadata]


def all_specs(cls: type) -> list[Param]:
    """Every parameter the dataclass ``cls`` declares, in order, with its start default: a group's
    ``<field>.<name>`` parameters included, ``default_from`` resolved from the defaults before it."""
    out: list[Param] = []
    values: dict[str, Any] = {}
    for f in dataclasses.fields(cls):
        if _GROUP in f.metadata:
            values[f.name] = f.metadata[_GROUP](values)
            out += dataclass_params(f.name, values[f.name])
            continue
        spec = dataclasses.replace(f.metadata[_PARAM], name=f.name)
        if spec.default_from is not None:
            spec = dataclasses.replace(spec, default=spec.default_from(values))
        values[f.name] = spec.default
        out.append(spec)
    return out


def declare(node: Node, cls: type) -> Any:
    """Declare the fields of the parameter dataclass ``cls`` on ``node``, in field order; return the instance.

    A ``cls.error_context(values)`` (optional) names what a bad value belongs to, from the fields
    declared before it (the player: its bag); it prefixes the error line."""
    values: dict[str, Any] = {}
    for f in dataclasses.fields(cls):
        try:
            values[f.name] = _declare_field(node, cls, f, values)
        except ParameterError as exc:
            where = cls.error_context(values) if hasattr(cls, 'error_context') else None
            raise ParameterError(f'{where}: {exc}' if where else str(exc)) from None
    return cls(**values)


def _declare_field(node: Node, cls: type, f: dataclasses.Field, values: Mapping[str, Any]) -> Any:
    if _GROUP in f.metadata:
        return declare_dataclass(node, f.name, f.metadata[_GROUP](values))
    if _PARAM not in f.metadata:
        raise TypeError(f'{cls.__name__}.{f.name}: declare it with param() or group()')
    spec = dataclasses.replace(f.metadata[_PARAM], name=f.name)
    if spec.default_from is not None:
        spec = dataclasses.replace(spec, default=spec.default_from(values))
    value = getattr(declare_params(node, [spec]), f.name)
    return list(value) if isinstance(value, list) else value  # never the default's own list
