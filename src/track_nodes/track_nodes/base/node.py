"""``TrackNode``, the base of every node, and ``run_node``, the ``main`` of every executable.

A node subclass names itself (``DEFAULT_NAME``), names its parameter dataclass (``Params``,
``base/params.py``) and, in ``setup()``, creates its core object and its endpoints; the base does
the rest:
- the standard constructor (``node_name``, ``context``, ``parameter_overrides``, ``cli_args``), then
  every field of ``Params`` declared, the checked values in ``self.p``;
- ``main(argv)`` (``base/run.py``): ``rclpy.init`` → build → spin until SIGINT, SIGTERM or SIGHUP
  (``base.signals``) or shutdown → destroy → exit code; a bad parameter or input at start
  (``ValueError``, ``OSError``) is one line on stderr and exit 2, no traceback;
- ``refuse(topic, reason)``: counted per kind, a new kind logged at once, the rest in one line per
  ``WARN_THROTTLE`` s (5; ``base.refusals``), and on ``/diagnostics`` at most once a second;
- topics: ``track_msgs_py.topics`` names are made relative (``topics.relative``) so ``__ns`` and
  remapping apply; a user's name is taken ``as_given``; every endpoint takes rclpy's QoS overrides
  (``-p qos_overrides./demo/track.publisher.depth:=50``);
- display twins: a publisher of ``topics.DISPLAY_TWINS`` also publishes ``<topic>/pose``
  (``base/twins.py``), unless taken as given;
- transforms (``track_msgs_py.tf``): ``send_transforms`` on ``/tf``; ``add_static_transforms``
  republishes all the node's static transforms on the latched ``/tf_static`` (stamped now, waiting
  for the first ``/clock`` under sim time); ``advertise_transforms()`` in ``setup()`` makes /tf
  visible before the first transform. ``python -m track_nodes <executable>`` looks the class up in
  ``track_nodes.registry`` and calls ``main``. In full: docs/MODULES.md, "TrackNode in full".
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence
from typing import Any, ClassVar

from diagnostic_msgs.msg import DiagnosticArray
from rcl_interfaces.msg import SetParametersResult
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos_overriding_options import QoSOverridingOptions

from track_msgs_py.diagnostics import diagnostic_array, diagnostic_status
from track_msgs_py.records import DIAG_OK, DIAG_WARN
from track_msgs_py.tf import TF, TF_QOS, TF_STATIC, TF_STATIC_QOS, tf_message
from track_msgs_py.topics import DIAGNOSTICS, display_twin, relative
from track_nodes.base import ready
from track_nodes.base.names import CheckedNames
from track_nodes.base.params import NoParams, Param, ParameterError, declare
from track_nodes.base.refusals import RefusalCounter
from track_nodes.base.teardown import dds_alarm
from track_nodes.base.timejump import watch_time_jumps
from track_nodes.base.twins import TwinnedPublisher, twin_class


def _overridable(node: Node, kwargs: dict) -> None:
    """Our endpoints take QoS overrides; rclpy's own (made inside ``Node.__init__``) are left alone."""
    if '_specs' in node.__dict__:
        kwargs.setdefault('qos_overriding_options', QoSOverridingOptions.with_default_policies())


class TrackNode(Node, metaclass=CheckedNames):
    """A node of this package set: declared parameters in ``self.p``, endpoints in ``__init__``; an
    undeclared parameter addressed to it is refused once it is built (``base/names.py``)."""

    DEFAULT_NAME: ClassVar[str] = 'track_node'
    Params: ClassVar[type] = NoParams  # the node's parameter dataclass (base/params.py)
    WARN_THROTTLE: ClassVar[float] = 5.0  # seconds between two summary lines of refusals (base/refusals.py)
    DIAGNOSTICS_PERIOD: ClassVar[float] = 1.0

    def __init__(self, *, node_name: str | None = None, context=None, parameter_overrides=None, cli_args=None,
                 **node_kwargs: Any) -> None:
        start_ns = time.time_ns()  # who came first of two nodes of one name (base/ready.py)
        super().__init__(node_name or self.DEFAULT_NAME, context=context, parameter_overrides=parameter_overrides,
                         cli_args=cli_args, **node_kwargs)
        self._specs: dict[str, Param] = {}  # every Param declared through declare_params (base/params.py)
        self._declaring: set[str] = set()
        self.p = declare(self, self.Params)
        self.refusals = RefusalCounter(self.WARN_THROTTLE)
        self._steady = Clock(clock_type=ClockType.STEADY_TIME)
        self._diagnostics = None  # publisher and timer made at the first refusal (most nodes never need them)
        self._diagnostics_dirty = False
        self._tf_pub = self._tf_static_pub = None  # made at the first transform (most nodes never broadcast)
        self._static_transforms: dict[str, Any] = {}  # child frame -> TransformStamped
        self._static_wait = None  # a timer on the node clock: /tf_static waits for the first /clock
        self.setup()
        self.time_jumps = watch_time_jumps(self)  # a clock jump calls reset_time_state (base/timejump.py)
        self.add_on_set_parameters_callback(self._check_params)
        self.add_post_set_parameters_callback(self._apply_params)
        ready.claim(self, start_ns)  # one node per name; the announcement on /track/ready (base/ready.py)

    def setup(self) -> None:
        """The node's core object and endpoints (parameters are in ``self.p``); raise ValueError to refuse."""

    def reset_time_state(self) -> tuple[str, ...]:
        """Forget what is kept in time order (watermarks, filters, windows) after a clock jump; name it."""
        return ()

    # -- topics: relative names (topics.relative) --------------------------------------------------
    def create_publisher(self, msg_type, topic: str, qos_profile, *, as_given: bool = False, **kwargs):
        _overridable(self, kwargs)
        pub = super().create_publisher(msg_type, topic if as_given else relative(topic), qos_profile, **kwargs)
        self._names()[topic] = pub.topic_name
        twin = None if as_given else twin_class(topic, msg_type)
        if twin is not None:  # Odometry, PointStamped: a drawable twin on <topic>/pose (base/twins.py)
            twin_pub = super().create_publisher(twin, relative(display_twin(topic)), qos_profile, **kwargs)
            return TwinnedPublisher(pub, twin_pub)
        return pub

    def destroy_publisher(self, publisher) -> bool:
        if isinstance(publisher, TwinnedPublisher):  # its display twin goes with it
            super().destroy_publisher(publisher.twin)
            publisher = publisher.publisher
        return super().destroy_publisher(publisher)

    def create_subscription(self, msg_type, topic: str, callback, qos_profile, *, as_given: bool = False,
                            **kwargs):
        _overridable(self, kwargs)
        sub = super().create_subscription(msg_type, topic if as_given else relative(topic), callback, qos_profile,
                                          **kwargs)
        self._names()[topic] = sub.topic_name
        return sub

    def _names(self) -> dict[str, str]:
        """Topic as the code gives it → the endpoint's resolved name (rclpy's own endpoints come first)."""
        return self.__dict__.setdefault('_resolved', {})

    def count_publishers(self, topic_name: str) -> int:
        return super().count_publishers(self.resolved(topic_name))

    def count_subscribers(self, topic_name: str) -> int:
        return super().count_subscribers(self.resolved(topic_name))

    def resolved(self, topic: str) -> str:
        """The fully qualified (namespaced, remapped) name of ``topic`` as this node uses it."""
        names = self._names()
        if topic in names:
            return names[topic]
        if topic in names.values():  # already resolved
            return topic
        return self.resolve_topic_name(relative(topic))

    # -- parameters at run time (base/params.py) -------------------------------------------------
    def validate_params(self, p: Any) -> None:
        """Cross-checks of a candidate parameter set ``p`` (all values, changes applied); raise ParameterError."""

    def apply_params(self, changed: set[str]) -> None:
        """Put the live parameters ``changed`` (already in ``self.p``) into effect."""

    def _check_params(self, params: list[Parameter]) -> SetParametersResult:
        # declare_parameter runs these callbacks too: a parameter not declared yet is being declared
        self._declaring = {q.name for q in params if not self.has_parameter(q.name)}
        changes = {q.name: q.value for q in params if q.name in self._specs and q.name not in self._declaring}
        try:
            for name, value in changes.items():
                spec = self._specs[name]
                if not spec.live:  # rclpy refuses read-only ones first; this is the guard if it did not
                    raise ParameterError(f'parameter {name} is read-only: set it at start')
                spec.check(value)
            if changes:
                self.validate_params(dataclasses.replace(self.p, **changes))
        except (ParameterError, ValueError) as exc:
            self.get_logger().warning(f'parameter change refused: {exc}')
            return SetParametersResult(successful=False, reason=str(exc))
        return SetParametersResult(successful=True)

    def _apply_params(self, params: list[Parameter]) -> None:
        changed = {q.name for q in params if q.name in self._specs and self._specs[q.name].live
                   and q.name not in self._declaring}
        for name in changed:
            setattr(self.p, name, self.get_parameter(name).value)
        if changed:
            self.apply_params(changed)
            said = ', '.join(f'{n}={getattr(self.p, n)!r}' for n in sorted(changed))
            self.get_logger().info(f'parameters set: {said}')

    def steady_now(self) -> float:
        return self._steady.now().nanoseconds * 1e-9

    def refuse(self, topic: str, reason: str) -> None:
        """Count and (throttled) log one refused message; the caller leaves its state unchanged."""
        line = self.refusals.refuse(self.resolved(topic), reason, self.steady_now())
        if line is not None:
            self.get_logger().warning(line)
        self._diagnostics_dirty = True
        if self._diagnostics is None:
            pub = self.create_publisher(DiagnosticArray, DIAGNOSTICS, 10)
            timer = self.create_timer(self.DIAGNOSTICS_PERIOD, self.publish_diagnostics, clock=self._steady)
            self._diagnostics = (pub, timer)
            self.publish_diagnostics()

    def publish_diagnostics(self) -> None:
        """The refusal counts on /diagnostics, when they changed since the last publication."""
        line = self.refusals.flush(self.steady_now())  # refusals that no later one has summed up yet
        if line is not None:
            self.get_logger().warning(line)
        if self._diagnostics is None or not self._diagnostics_dirty:
            return
        self._diagnostics_dirty = False
        counts = self.refusals.by_key()
        status = diagnostic_status(self.get_fully_qualified_name(), DIAG_WARN if counts else DIAG_OK,
                                   f'{self.refusals.total()} messages refused', counts)
        self._diagnostics[0].publish(diagnostic_array(self.get_clock().now().nanoseconds * 1e-9, [status]))

    def advertise_transforms(self) -> None:
        """Create the /tf publisher now (in ``setup``), not at the first transform: nothing sent is lost."""
        if self._tf_pub is None:
            from tf2_msgs.msg import TFMessage

            self._tf_pub = self.create_publisher(TFMessage, TF, TF_QOS)

    def send_transforms(self, *transforms) -> None:
        """Publish dynamic ``TransformStamped`` s on /tf in one message (stamp them at the data they place)."""
        self.advertise_transforms()
        self._tf_pub.publish(tf_message(transforms))

    def add_static_transforms(self, *transforms) -> None:
        """Add fixed transforms (replacing any with the same child frame) and republish all on /tf_static."""
        for tr in transforms:
            self._static_transforms[tr.child_frame_id] = tr
        if self._tf_static_pub is None:
            from tf2_msgs.msg import TFMessage

            self._tf_static_pub = self.create_publisher(TFMessage, TF_STATIC, TF_STATIC_QOS)
        self.publish_static_transforms()

    def publish_static_transforms(self) -> None:
        """All static transforms on /tf_static, stamped now; before a sim clock's first reading, at that reading."""
        if self._tf_static_pub is None or not self._static_transforms:
            return
        now = self.get_clock().now()
        if now.nanoseconds == 0:  # a ROS-time timer fires once the clock runs (at the first /clock)
            if self._static_wait is None:
                self._static_wait = self.create_timer(1e-3, self.publish_static_transforms)
            return
        if self._static_wait is not None:
            self.destroy_timer(self._static_wait)
            self._static_wait = None
        stamp = now.to_msg()
        for tr in self._static_transforms.values():
            tr.header.stamp = stamp
        self._tf_static_pub.publish(tf_message(list(self._static_transforms.values())))

    def destroy_node(self) -> None:
        """Delete the DDS entities (subclasses close their files first, then call this)."""
        ready.release(self)
        if getattr(self, 'time_jumps', None) is not None:
            self.time_jumps.close()
        with dds_alarm():
            super().destroy_node()

    @classmethod
    def main(cls, argv: Sequence[str] | None = None, **kwargs: Any) -> int:
        from track_nodes.base.run import run_node

        return run_node(cls, argv, **kwargs)
