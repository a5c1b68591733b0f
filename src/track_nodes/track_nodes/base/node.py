"""``TrackNode``, the base of every node, and ``run_node``, the ``main`` of every executable.

A node subclass names itself (``DEFAULT_NAME``), lists its parameters (``PARAMS``) and, in
``setup()``, creates its core object and its endpoints; the base does the rest:

- the standard constructor (``node_name``, ``context``, ``parameter_overrides``, ``cli_args``,
  as the launcher and the tests call it), then ``declare_params(PARAMS)`` into ``self.p``;
- ``main(argv)``: ``rclpy.init`` → build the node → spin until SIGINT/SIGTERM or shutdown →
  destroy (which closes files) → exit code. A bad parameter or bad input at start
  (``ValueError``, ``OSError``) prints one line on stderr and exits 2, without a traceback.

Refused input goes through ``refuse(topic, reason)``: counted per reason, logged at most once
per reason every ``warn_throttle`` seconds with the count (``base.refusals``), and published on
``/diagnostics`` (one ``DiagnosticStatus`` named after the node, a key per topic and reason) at
most once a second while refusals happen, so ``ros2 topic echo /diagnostics`` shows them.

Transforms (``track_msgs_py.tf``): ``send_transforms(*ts)`` publishes dynamic transforms on ``/tf``;
``add_static_transforms(*ts)`` adds fixed ones (a later one with the same child frame replaces the
earlier) and republishes ALL of the node's static transforms as one message on the latched
``/tf_static``, as tf2_ros's StaticTransformBroadcaster does. Both publishers are made at the first
call, so a node that never broadcasts has no /tf endpoint; a node that will broadcast calls
``advertise_transforms()`` in ``setup()``, so that a recorder (and the launcher, which waits for the
recorder's subscriptions before it starts the clock) sees /tf before the first transform is sent.

``python -m track_nodes <executable>`` (what the ``ros2 run`` shims call) looks the class up in
``track_nodes.registry`` and calls ``main``.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Sequence
from typing import Any, ClassVar

import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.clock import Clock, ClockType
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node

from track_msgs_py.convert import diagnostic_array, diagnostic_status
from track_msgs_py.records import DIAG_OK, DIAG_WARN
from track_msgs_py.tf import TF, TF_QOS, TF_STATIC, TF_STATIC_QOS, tf_message
from track_msgs_py.topics import DIAGNOSTICS
from track_nodes.base.params import Param, declare_params
from track_nodes.base.refusals import RefusalCounter

EXIT_BAD_INPUT = 2



class TrackNode(Node):
    """A node of this package set: declared parameters in ``self.p``, endpoints in ``__init__``."""

    DEFAULT_NAME: ClassVar[str] = 'track_node'
    PARAMS: ClassVar[tuple[Param, ...]] = ()
    WARN_THROTTLE: ClassVar[float] = 5.0  # seconds between two log lines about one kind of refusal
    DIAGNOSTICS_PERIOD: ClassVar[float] = 1.0

    def __init__(self, *, node_name: str | None = None, context=None, parameter_overrides=None, cli_args=None,
                 **node_kwargs: Any) -> None:
        super().__init__(node_name or self.DEFAULT_NAME, context=context, parameter_overrides=parameter_overrides,
                         cli_args=cli_args, **node_kwargs)
        self.p = declare_params(self, self.PARAMS)
        self.refusals = RefusalCounter(self.WARN_THROTTLE)
        self._steady = Clock(clock_type=ClockType.STEADY_TIME)
        self._diagnostics = None  # publisher and timer made at the first refusal (most nodes never need them)
        self._diagnostics_dirty = False
        self._tf_pub = self._tf_static_pub = None  # made at the first transform (most nodes never broadcast)
        self._static_transforms: dict[str, Any] = {}  # child frame -> TransformStamped
        self.setup()

    def setup(self) -> None:
        """The node's core object and endpoints (parameters are in ``self.p``); raise ValueError to refuse."""

    def steady_now(self) -> float:
        return self._steady.now().nanoseconds * 1e-9

    def refuse(self, topic: str, reason: str) -> None:
        """Count and (throttled) log one refused message; the caller leaves its state unchanged."""
        line = self.refusals.refuse(topic, reason, self.steady_now())
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
        self._tf_static_pub.publish(tf_message(list(self._static_transforms.values())))

    @classmethod
    def main(cls, argv: Sequence[str] | None = None, **kwargs: Any) -> int:
        return run_node(cls, argv, **kwargs)


def run_node(factory: Callable[..., Node], argv: Sequence[str] | None = None, **kwargs: Any) -> int:
    """Run one node until shutdown; return the process exit code (0, or 2 for bad input)."""
    args = list(sys.argv if argv is None else argv)
    rclpy.init(args=args)
    try:
        node = factory(**kwargs)
    except (ValueError, OSError) as exc:
        name = getattr(factory, 'DEFAULT_NAME', getattr(factory, '__name__', 'node'))
        print(f'{name}: {exc}', file=sys.stderr)
        rclpy.try_shutdown()
        return EXIT_BAD_INPUT
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return getattr(node, 'exit_code', 0)
