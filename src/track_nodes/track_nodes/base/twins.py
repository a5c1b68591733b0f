"""Display twins: a publisher of ``Odometry`` or ``PointStamped`` that also publishes the drawable twin.

Foxglove's 3D panel draws neither type (``track_msgs_py.display.FOXGLOVE_3D_TYPES``), so
``TrackNode.create_publisher`` pairs a publisher of a topic of ``topics.DISPLAY_TWINS`` (those the
shipped layouts draw) with one on ``<topic>/pose`` (``topics.display_twin``, same QoS) and returns a
``TwinnedPublisher``: ``publish(msg)`` publishes the
message, then its twin (``display.display_twin``). Raw bytes (a player's replay) go out alone: a
recording holds the twin topic itself. Everything else is the wrapped publisher's.
"""

from __future__ import annotations

from typing import Any

from track_msgs_py.display import display_twin
from track_msgs_py.topics import DISPLAY_TWINS, TWIN_TYPES


def type_name(msg_type: type) -> str:
    """``nav_msgs.msg.Odometry`` → ``'nav_msgs/msg/Odometry'``."""
    return f'{msg_type.__module__.split(".")[0]}/msg/{msg_type.__name__}'


def twin_class(topic: str, msg_type: type) -> type | None:
    """The message class of the display twin of ``topic`` (a name of ``topics``), or None when it has none."""
    twin = TWIN_TYPES.get(type_name(msg_type)) if topic in DISPLAY_TWINS else None
    if twin is None:
        return None
    from geometry_msgs import msg

    return getattr(msg, twin.rpartition('/')[2])


class TwinnedPublisher:
    """A publisher and the publisher of its display twin."""

    def __init__(self, publisher, twin) -> None:
        self.publisher = publisher
        self.twin = twin

    def publish(self, msg: Any) -> None:
        self.publisher.publish(msg)
        if not isinstance(msg, bytes | bytearray | memoryview):
            self.twin.publish(display_twin(msg))

    # A managed node (base/lifecycle.py) switches both on and off; destroying one destroys both
    # (TrackNode.destroy_publisher).
    def on_activate(self, state: Any) -> None:
        self.publisher.on_activate(state)
        self.twin.on_activate(state)

    def on_deactivate(self, state: Any) -> None:
        self.publisher.on_deactivate(state)
        self.twin.on_deactivate(state)

    def __getattr__(self, name: str) -> Any:
        return getattr(self.publisher, name)
