"""track_msgs_py: topic names, QoS profiles, conversions and validation for standard messages.

The only layer that knows both track_core types and ROS messages. Every topic uses a type
from common_interfaces, so ``ros2 topic echo``, rosbags and Foxglove read it without our code.

Modules (imported explicitly, so ``topics`` stays free of message imports):

- ``topics``: topic-name constants, the ``TOPICS`` table (type, QoS kind, description), frames.
- ``qos``: ``SENSOR_QOS``, ``ESTIMATE_QOS``, ``STATIC_QOS``, ``CLOCK_QOS``, ``qos_for_topic``.
- ``convert``: numpy/float seconds ⇄ messages; the mapping table is its module docstring.
- ``validate``: reasons (``str | None``) why an incoming message is unusable, monotonic stamps.
"""
