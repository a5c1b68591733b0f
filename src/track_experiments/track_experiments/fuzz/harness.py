"""Run one fuzz case in-process: the scenario's nodes, a prober, bad messages, then the verdict.

1. **Warm-up**: the case's nodes (``table.FuzzCase``) run on a fresh context; the prober subscribes
   to every topic the target subscribes to (their last valid message becomes the template of the
   bad ones) and publishes to, and waits until every ``alive`` topic has output.
2. **Attack**: ``messages`` bad messages (``generate.Fuzzer``), each published with the QoS of the
   target's subscription (bytes go out raw), the ready callbacks run after each; the drivers keep
   sending valid input in between.
3. **After**: valid input only; ``alive`` when every ``alive`` topic gets new output in time.

Counted all along: output messages per topic and NaN/inf in any of their floats (PointCloud2
float fields and numeric diagnostic values included); WARN-or-worse lines of the target's logger,
read from ``/rosout`` (everything the node logs, through any API, goes there); exceptions raised by
callbacks (with the traceback), which a process would die of.
"""

from __future__ import annotations

import os
import time
import traceback
from dataclasses import dataclass, field
from typing import Any

import rclpy
from rcl_interfaces.msg import Log
from rclpy.context import Context
from rclpy.executors import ExternalShutdownException, ShutdownException, SingleThreadedExecutor, TimeoutException
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock

from track_experiments.fuzz.fields import nonfinite
from track_experiments.fuzz.generate import Fuzzer
from track_experiments.fuzz.table import FuzzCase, default_template
from track_msgs_py.qos import CLOCK_QOS
from track_nodes.registry import node_class

SKIP_TOPICS = frozenset({'/parameter_events', '/rosout', '/clock'})
WARN = 30
CLOCK_TICK = 0.05  # wall s between two /clock messages (sim-time cases)
TEMPLATE_TIMEOUT = 5.0  # wall s more for a template of every attacked topic (some have no publisher)
PUMP_EVERY = 25  # bad messages between two short pumps that let the drivers' timers run


@dataclass
class FuzzResult:
    case: str
    sent: int = 0
    kinds: dict[str, int] = field(default_factory=dict)
    alive: bool = False
    output_before: dict[str, int] = field(default_factory=dict)
    output_after: dict[str, int] = field(default_factory=dict)
    nan_outputs: dict[str, int] = field(default_factory=dict)  # topic → messages with NaN/inf
    nan_examples: list[str] = field(default_factory=list)
    refusals: dict[str, int] = field(default_factory=dict)
    log_lines: int = 0
    log_examples: dict[str, int] = field(default_factory=dict)  # a line's first 60 characters → count
    crashes: list[str] = field(default_factory=list)
    attack_seconds: float = 0.0
    counted_seconds: float = 0.0  # from the first bad message to the end of the log count
    missing_templates: list[str] = field(default_factory=list)

    @property
    def lines_per_bad(self) -> float:
        return self.log_lines / self.sent if self.sent else 0.0

    def summary(self) -> dict[str, Any]:
        return {'case': self.case, 'sent': self.sent, 'alive': self.alive, 'output_before': self.output_before,
                'output_after': self.output_after, 'nan_outputs': self.nan_outputs,
                'nan_examples': self.nan_examples[:5], 'refusals': self.refusals, 'log_lines': self.log_lines,
                'log_examples': dict(sorted(self.log_examples.items(), key=lambda kv: -kv[1])[:10]),
                'lines_per_bad': self.lines_per_bad, 'crashes': len(self.crashes),
                'tracebacks': self.crashes[:3], 'kinds': self.kinds, 'attack_seconds': self.attack_seconds,
                'counted_seconds': self.counted_seconds,
                'missing_templates': self.missing_templates}


class _Prober:
    def __init__(self, context: Context, target: Node, alive: tuple[str, ...], result: FuzzResult) -> None:
        self.node = Node('fuzz_prober', context=context, enable_rosout=False)
        self.result = result
        self.logger_name = target.get_logger().name
        self.templates: dict[str, Any] = {}
        self.types: dict[str, type] = {}
        self.pubs: dict[str, Any] = {}
        self.out_counts: dict[str, int] = {}
        self.log_lines = 0
        self.alive = alive
        for sub in target.subscriptions:
            topic = sub.topic_name
            if topic in SKIP_TOPICS or topic in self.pubs:
                continue
            self.types[topic] = sub.msg_type
            qos = QoSProfile(depth=max(sub.qos_profile.depth, 10), reliability=ReliabilityPolicy.RELIABLE,
                             durability=sub.qos_profile.durability)
            self.pubs[topic] = self.node.create_publisher(sub.msg_type, topic, qos)
            self.node.create_subscription(sub.msg_type, topic, lambda m, t=topic: self._template(t, m),
                                          _listen_qos(sub.qos_profile, sub.qos_profile.durability))
        for pub in target.publishers:
            topic = pub.topic_name
            if topic in SKIP_TOPICS or topic in self.out_counts:
                continue
            self.out_counts[topic] = 0
            self.node.create_subscription(pub.msg_type, topic, lambda m, t=topic: self._output(t, m),
                                          _listen_qos(pub.qos_profile))
        for topic in alive:
            self.out_counts.setdefault(topic, 0)
        self.node.create_subscription(Log, '/rosout', self._log, QoSProfile(depth=1000))
        self.taking_templates = True

    def _template(self, topic: str, msg) -> None:
        if self.taking_templates:
            self.templates[topic] = msg

    def _output(self, topic: str, msg) -> None:
        self.out_counts[topic] = self.out_counts.get(topic, 0) + 1
        where = nonfinite(msg)
        # A topic the node both reads and writes (the IDSQ election) carries the attacker's messages too:
        # their NaN are the attack's, not the node's output.
        if where is not None and topic not in self.pubs:
            self.result.nan_outputs[topic] = self.result.nan_outputs.get(topic, 0) + 1
            if len(self.result.nan_examples) < 20:
                self.result.nan_examples.append(f'{topic}: {where}')

    def _log(self, msg: Log) -> None:
        if msg.name == self.logger_name and msg.level >= WARN:
            self.log_lines += 1
            head = msg.msg[:60]
            self.result.log_examples[head] = self.result.log_examples.get(head, 0) + 1
            if 'Traceback' in msg.msg:
                self.result.crashes.append(msg.msg)


def _listen_qos(qos: QoSProfile, durability=DurabilityPolicy.VOLATILE) -> QoSProfile:
    """Best effort (matches any publisher); the target's own durability for templates (latched layouts)."""
    return QoSProfile(depth=max(qos.depth, 10), reliability=ReliabilityPolicy.BEST_EFFORT, durability=durability)


class _Runner:
    """Runs ready callbacks; on sim time it also drives ``/clock``.

    The clock runs at ``rate`` x wall time, except during the attack, when it is tied to the count of
    bad messages sent: the attack spans at most ``case.attack_span`` sim s however long it takes in wall
    time, so a finite scenario (the IDSQ vehicle leaves the field at 36 s) still has valid input after it.
    """

    def __init__(self, executor: SingleThreadedExecutor, context: Context, result: FuzzResult,
                 clock_pub=None, rate: float = 0.0) -> None:
        self.executor, self.context, self.result = executor, context, result
        self.clock_pub, self.rate = clock_pub, rate
        self.sim = float(int(time.time()) // 60 * 60)  # like the launcher's default --epoch (ROS time 0 is unset)
        self.sim_cap: float | None = None  # attack: the clock may not pass this
        self.last_wall = time.monotonic()
        self.last_tick = -1.0

    def tick(self) -> None:
        """Sim time: advance by ``rate`` x the wall time since the last tick (up to ``sim_cap``), publish."""
        now = time.monotonic()
        if self.clock_pub is None or now - self.last_tick < CLOCK_TICK:
            return
        self.last_tick = now
        self.sim += self.rate * (now - self.last_wall)
        self.last_wall = now
        if self.sim_cap is not None:
            self.sim = min(self.sim, self.sim_cap)
        msg = Clock()
        sec, nsec = divmod(int(self.sim * 1e9), 10**9)
        msg.clock.sec, msg.clock.nanosec = sec, nsec
        self.clock_pub.publish(msg)

    def run_ready(self, first_wait: float = 0.0) -> None:
        """Run every ready callback (waiting ``first_wait`` s for the first); a raise is a crash."""
        wait = first_wait
        self.tick()
        while self.context.ok():
            try:
                handler, _, _ = self.executor.wait_for_ready_callbacks(timeout_sec=wait)
            except TimeoutException:
                return
            except (ShutdownException, ExternalShutdownException):
                return
            wait = 0.0
            handler()
            exc = handler.exception()
            if exc is not None:
                self.result.crashes.append(''.join(traceback.format_exception(exc)))

    def pump(self, seconds: float) -> None:
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline and self.context.ok():
            self.run_ready(first_wait=min(0.01, max(0.0, deadline - time.monotonic())))

    def until(self, predicate, timeout: float) -> bool:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if predicate():
                return True
            self.run_ready(first_wait=0.02)
        return bool(predicate())


def _build(case: FuzzCase, context: Context, executor: SingleThreadedExecutor, nodes: list[Node]) -> Node:
    """The case's nodes (appended to ``nodes``, added to ``executor``); returns the target."""
    cli = ['--ros-args', '--params-file', str(case.config_path())]
    target = None
    for executable, name in case.nodes:
        over = [Parameter(k, value=v) for k, v in case.overrides.get(name, {}).items()]
        over.append(Parameter('use_sim_time', value=case.sim_rate > 0))
        node = node_class(executable)(node_name=name, context=context, cli_args=cli, parameter_overrides=over)
        nodes.append(node)
        executor.add_node(node)
        if name == case.target:
            target = node
    if target is None:
        raise ValueError(f'{case.name}: target {case.target} is not among its nodes')
    return target


def _attack(case: FuzzCase, messages: int, fuzzer: Fuzzer, prober: _Prober, runner: _Runner,
            result: FuzzResult) -> None:
    """Send the bad messages, running the ready callbacks after each (sim time: ``case.attack_span`` at most)."""
    t0, sim0 = time.monotonic(), runner.sim
    for i in range(messages):
        if case.sim_rate > 0:
            runner.sim_cap = sim0 + case.attack_span * (i + 1) / messages
        bad = fuzzer.next()
        prober.pubs[bad.topic].publish(bad.msg)
        result.sent += 1
        result.kinds[bad.kind] = result.kinds.get(bad.kind, 0) + 1
        runner.run_ready(first_wait=0.005)
        if i % PUMP_EVERY == PUMP_EVERY - 1:
            runner.pump(0.02)
    result.attack_seconds = time.monotonic() - t0
    runner.sim_cap = None


def run_case(case: FuzzCase, messages: int, seed: int = 0, domain_id: int | None = None,
             warmup_timeout: float = 60.0, after_timeout: float = 60.0) -> FuzzResult:
    """Fuzz ``case.target`` with ``messages`` bad messages; see the module docstring."""
    result = FuzzResult(case.name)
    context = Context()
    domain = domain_id if domain_id is not None else int(os.environ.get('ROS_DOMAIN_ID', '0'))
    rclpy.init(context=context, domain_id=domain)
    executor = SingleThreadedExecutor(context=context)
    nodes: list[Node] = []
    try:
        target = _build(case, context, executor, nodes)
        prober = _Prober(context, target, case.alive, result)
        nodes.append(prober.node)
        executor.add_node(prober.node)
        clock_pub = None
        if case.sim_rate > 0:
            clock_pub = prober.node.create_publisher(Clock, '/clock', CLOCK_QOS)
        runner = _Runner(executor, context, result, clock_pub, case.sim_rate)

        def outputs_seen(base: dict[str, int], k: int) -> bool:
            return all(prober.out_counts.get(t, 0) - base.get(t, 0) >= k for t in case.alive)

        runner.until(lambda: outputs_seen({}, case.min_output), warmup_timeout)
        runner.until(lambda: all(t in prober.templates for t in prober.types), TEMPLATE_TIMEOUT)
        prober.taking_templates = False
        result.output_before = dict(prober.out_counts)
        for topic, cls in prober.types.items():
            if topic not in prober.templates:
                result.missing_templates.append(topic)
                prober.templates[topic] = default_template(cls, target)
        fuzzer = Fuzzer({t: m for t, m in prober.templates.items() if t not in case.skip_topics}, seed)
        lines0 = prober.log_lines
        t0 = time.monotonic()
        _attack(case, messages, fuzzer, prober, runner, result)
        runner.pump(0.5)  # the last bad messages and their log lines arrive
        mid = dict(prober.out_counts)
        result.alive = runner.until(lambda: outputs_seen(mid, case.min_output), after_timeout)
        runner.pump(0.5)
        result.output_after = {t: prober.out_counts[t] - mid.get(t, 0) for t in prober.out_counts}
        result.log_lines = prober.log_lines - lines0
        result.counted_seconds = time.monotonic() - t0
        counter = getattr(target, 'refusals', None)
        result.refusals = counter.by_key() if counter is not None else {}
    finally:
        for node in nodes:
            executor.remove_node(node)
            node.destroy_node()
        executor.shutdown()
        context.try_shutdown()
    return result
