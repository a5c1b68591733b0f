"""Managed (lifecycle) nodes: ``managed(NodeClass)`` is the node run through the ROS 2 lifecycle states.

The ``lifecycle_<executable>`` executables (``registry``) are the estimator nodes made managed here,
for an orchestrator (``ros2 lifecycle set``, launch_ros' ``LifecycleNode``, nav2's lifecycle
manager); the plain executables stay as they are. States, transitions and services are rcl's
(``rclpy.lifecycle``, ``lifecycle_msgs``: ``~/change_state``, ``~/get_state``, ...):

- **unconfigured** (after construction): the parameters are declared and checked as in the plain
  node (a bad one still stops the process with one line), the node answers the lifecycle services
  and parameter requests; it has no core object and no topic endpoint.
- **configure** → inactive: the node's ``setup()`` runs (core object, publishers, subscriptions,
  timers: the plain node's construction). Publishers are ``LifecyclePublisher`` s, silent until
  activated; timers are cancelled; a subscription's messages are held, not processed, as the
  subscription's own history would hold them (its QoS depth, the oldest dropped first). A ``ValueError``
  or ``OSError`` of ``setup()`` (a bad combination of parameters, a missing file) fails the
  transition with one error line, and what it had made is destroyed: the node stays unconfigured.
- **activate** → active: publishers on, the held messages handed to their callbacks in arrival
  order, timers restarted (a step clock, ``FixedRateSteps``, catches up to the current node time),
  the static transforms republished on ``/tf_static`` (they were silent at configure). The node then
  works as the plain one. Holding, not dropping, keeps a lock-step partner going: ``smart_target``
  publishes its first truth once and waits for the observer's answer to it.
- **deactivate** → inactive: publishers off, timers cancelled, messages held again; the core's
  state is kept, so activating again continues the estimate.
- **cleanup** → unconfigured (and **shutdown** → finalized, from any state): every endpoint and
  timer made since construction is destroyed and the attributes ``setup()`` set are dropped, so the
  next configure starts afresh (parameters changed meanwhile apply then).

Live parameters can be set in any state; before configure they are only stored (``setup()`` reads
them). A clock jump resets the core only when there is one.
"""

from __future__ import annotations

import functools
import itertools
from collections import deque
from typing import Any

from rclpy.lifecycle import LifecycleNodeMixin, LifecyclePublisher, LifecycleState, TransitionCallbackReturn

SUCCESS, FAILURE = TransitionCallbackReturn.SUCCESS, TransitionCallbackReturn.FAILURE
HELD_MAX = 10_000  # messages held per subscription while inactive when its QoS keeps all (KEEP_ALL)
# Attributes of the base that setup() and later calls fill lazily: back to their empty value at cleanup.
_LAZY = {'_tf_pub': None, '_tf_static_pub': None, '_diagnostics': None, '_static_wait': None}


class _Managed(LifecycleNodeMixin):
    """The lifecycle half of a managed node; ``managed`` puts it in front of a ``TrackNode`` subclass."""

    def __init__(self, **kwargs: Any) -> None:
        self._lc_ready = False          # the base's construction (not setup()) is running
        self._configured = self._active = False
        self._lc_made: dict[str, list] = {'pub': [], 'sub': [], 'timer': []}
        self._lc_held: list[deque] = []   # per subscription: (arrival number, callback, message) while inactive
        self._lc_arrival = itertools.count()
        self._lc_plain = None           # the node class's own setup(), deferred to configure
        super(LifecycleNodeMixin, self).__init__(**kwargs)   # the TrackNode subclass (setup() deferred)
        LifecycleNodeMixin.__init__(self, enable_communication_interface=True)
        self._lc_ready = True

    # -- construction: setup() waits for configure ------------------------------------------------
    def setup(self) -> None:
        if self._lc_ready:
            super().setup()

    def apply_params(self, changed: set[str]) -> None:
        if self._configured:  # before configure the values only wait in self.p
            super().apply_params(changed)

    def reset_time_state(self) -> tuple[str, ...]:
        return super().reset_time_state() if self._configured else ()

    # -- endpoints made after construction are the lifecycle's -----------------------------------------
    def create_publisher(self, *args, **kwargs):
        if not self._lc_ready:
            return super().create_publisher(*args, **kwargs)
        pub = super().create_publisher(*args, publisher_class=LifecyclePublisher, **kwargs)
        self._lc_made['pub'].append(pub)
        if self._active:  # made while active (a first refusal's /diagnostics): on at once
            pub.on_activate(None)
        return pub

    def create_subscription(self, msg_type, topic, callback, qos_profile, **kwargs):
        if not self._lc_ready:
            return super().create_subscription(msg_type, topic, callback, qos_profile, **kwargs)

        depth = getattr(qos_profile, 'depth', qos_profile) or HELD_MAX   # an int is a depth too (rclpy)
        held: deque = deque(maxlen=min(int(depth), HELD_MAX))

        def gated(msg, callback=callback, held=held):
            if self._active:
                callback(msg)
            else:
                held.append((next(self._lc_arrival), callback, msg))

        sub = super().create_subscription(msg_type, topic, gated, qos_profile, **kwargs)
        self._lc_made['sub'].append(sub)
        self._lc_held.append(held)
        return sub

    def create_timer(self, *args, **kwargs):
        timer = super().create_timer(*args, **kwargs)
        if self._lc_ready:
            self._lc_made['timer'].append(timer)
            if not self._active:
                timer.cancel()
        return timer

    def destroy_timer(self, timer) -> bool:
        if timer in self._lc_made['timer']:
            self._lc_made['timer'].remove(timer)
        return super().destroy_timer(timer)

    # -- transitions ---------------------------------------------------------------------------------
    def on_configure(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._lc_before = set(self.__dict__)
        try:
            super().setup()
        except (ValueError, OSError) as exc:
            self.get_logger().error(f'configure failed: {exc}')
            self._drop_configuration()
            return FAILURE
        self._configured = True
        for timer in self._lc_made['timer']:
            timer.cancel()
        self.get_logger().info('configured (inactive)')
        return SUCCESS

    def on_activate(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._active = True
        for pub in self._lc_made['pub']:
            pub.on_activate(state)
        self.publish_static_transforms()
        held = sorted((item for q in self._lc_held for item in q), key=lambda item: item[0])
        for q in self._lc_held:
            q.clear()
        for _, callback, msg in held:
            callback(msg)
        for timer in self._lc_made['timer']:
            timer.reset()
        self.get_logger().info('active')
        return SUCCESS

    def on_deactivate(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._active = False
        for pub in self._lc_made['pub']:
            pub.on_deactivate(state)
        for timer in self._lc_made['timer']:
            timer.cancel()
        self.get_logger().info('inactive')
        return SUCCESS

    def on_cleanup(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._drop_configuration()
        self.get_logger().info('cleaned up (unconfigured)')
        return SUCCESS

    def on_shutdown(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._active = False
        self._drop_configuration()
        return SUCCESS

    def on_error(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._active = False
        self._drop_configuration()
        return SUCCESS  # back to unconfigured

    def _drop_configuration(self) -> None:
        """Destroy every endpoint and timer made since construction; forget what setup() set."""
        made, self._lc_made = self._lc_made, {'pub': [], 'sub': [], 'timer': []}
        self._lc_held = []
        for timer in made['timer']:
            super().destroy_timer(timer)
        for sub in made['sub']:
            self.destroy_subscription(sub)
        for pub in made['pub']:
            self.destroy_publisher(pub)
        for name in set(self.__dict__) - getattr(self, '_lc_before', set(self.__dict__)):
            if not name.startswith('_lc_'):
                del self.__dict__[name]
        for name, empty in _LAZY.items():
            setattr(self, name, empty)
        self._static_transforms.clear()
        self._configured = False


@functools.cache
def managed(cls: type) -> type:
    """The managed (lifecycle) version of the ``TrackNode`` subclass ``cls``: same name, parameters and work."""
    doc = (cls.__doc__ or '').strip() or ''
    name = f'Lifecycle{cls.__name__}'
    return type(cls)(name, (_Managed, cls), {
        '__doc__': f'Managed (lifecycle) {cls.DEFAULT_NAME}: configure → activate → deactivate → cleanup through '
                   f'the lifecycle_msgs services; nothing is published before activate (track_nodes.base.lifecycle). '
                   f'{doc}',
        '__module__': cls.__module__, '__qualname__': name})
