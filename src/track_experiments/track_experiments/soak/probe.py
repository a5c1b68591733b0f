"""What a soak's outside observer sees of a run: its /clock and, for a long run, its estimator outputs.

For the long runs (``OutputProbe``) an rclpy node on the run's domain (in the soak's own process)
notes, for every output message, the wall time it arrived and its ``header.stamp`` (the data time
it belongs to), and the wall time at which /clock passed each whole data second. That is enough to
say how many outputs each stretch of data time produced and how much wall time it took, for one
process or for many, without reaching into the run.
"""

from __future__ import annotations

import time

from track_msgs_py.topics import FUSION_SCORES, IDSQ_ESTIMATE, SONAR_ESTIMATE, TOPICS

#: The maritime scenario's estimator outputs: the observer's SS-PF, the sensor network's IDSQ, the fusion.
OUTPUTS = (SONAR_ESTIMATE, IDSQ_ESTIMATE, FUSION_SCORES)
NS = 1_000_000_000


class ClockProbe:
    """An rclpy node of the soak's own on a run's domain, hearing its /clock (``_on_clock``); a context manager.

    rclpy's signal handlers are left out: they would take Ctrl-C and SIGTERM to shut the context down
    quietly, and the soak must see them (a KeyboardInterrupt) to stop the run it started.
    """

    name = 'soak_probe'

    def __init__(self, domain_id: int) -> None:
        self.domain_id = domain_id

    def __enter__(self):
        import rclpy
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.signals import SignalHandlerOptions
        from rosgraph_msgs.msg import Clock

        from track_msgs_py.qos import CLOCK_QOS

        self.context = Context()
        rclpy.init(context=self.context, domain_id=self.domain_id, signal_handler_options=SignalHandlerOptions.NO)
        self.node = rclpy.create_node(self.name, context=self.context, start_parameter_services=False)
        self.node.create_subscription(Clock, '/clock', self._on_clock, CLOCK_QOS)
        self.subscribe(self.node)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        return self

    def __exit__(self, *exc) -> None:
        self.executor.shutdown()
        self.node.destroy_node()
        self.context.try_shutdown()

    def subscribe(self, node) -> None:
        """The subscriptions beside /clock."""

    def _on_clock(self, msg) -> None:
        raise NotImplementedError

    def spin(self, seconds: float) -> None:
        deadline = time.monotonic() + seconds
        while (left := deadline - time.monotonic()) > 0:
            self.executor.spin_once(timeout_sec=min(left, 0.1))

    def spin_until(self, predicate, deadline: float) -> bool:
        """Spin until ``predicate()`` or the monotonic ``deadline``; → ``predicate()``."""
        while time.monotonic() < deadline:
            if predicate():
                return True
            self.executor.spin_once(timeout_sec=0.1)
        return predicate()


class OutputProbe(ClockProbe):
    """``spin(seconds)`` takes what arrived; ``data_s`` is the clock's data time."""

    name = 'soak_long_probe'

    def __init__(self, domain_id: int, topics: tuple[str, ...] = OUTPUTS) -> None:
        super().__init__(domain_id)
        self.topics = topics
        self.epoch_ns: int | None = None  # the first /clock: the launcher holds it at the epoch while settling
        self.clock: list[tuple[float, int]] = []  # (wall, data s) when /clock first reached each whole data second
        self.outputs: dict[str, list[tuple[float, int]]] = {t: [] for t in topics}  # (wall, stamp ns)

    def subscribe(self, node) -> None:
        from track_msgs_py.qos import qos_for_topic
        from track_nodes.bag.api import msg_class

        for topic in self.topics:
            node.create_subscription(msg_class(TOPICS[topic].msgtype), topic,
                                     lambda data, topic=topic: self._on_output(topic, data),
                                     qos_for_topic(topic), raw=True)

    def _on_clock(self, msg) -> None:
        t = msg.clock.sec * NS + msg.clock.nanosec
        if self.epoch_ns is None:
            self.epoch_ns = t
        s = (t - self.epoch_ns) // NS
        if s > (self.clock[-1][1] if self.clock else -1):
            self.clock.append((time.monotonic(), s))

    def _on_output(self, topic: str, data: bytes) -> None:
        from track_nodes.launch.pacing import header_stamp_ns

        if (t := header_stamp_ns(data)) is not None:
            self.outputs[topic].append((time.monotonic(), t))

    @property
    def data_s(self) -> float:
        """The data seconds the clock has reached (0 before it started)."""
        return float(self.clock[-1][1]) if self.clock else 0.0
