"""track_msgs_py: topic names, QoS profiles, conversions and validation for standard messages.

The only layer that knows both track_core types and ROS messages. Every topic uses a type
from common_interfaces, so ``ros2 topic echo``, rosbags and Foxglove read it without our code.

Modules (imported explicitly, so ``topics`` stays free of message imports):

- ``topics``: topic-name constants, the ``TOPICS`` table (type, QoS kind, description), frames.
- ``qos``: ``SENSOR_QOS``, ``ESTIMATE_QOS``, ``STATIC_QOS``, ``CLOCK_QOS``, ``qos_for_topic``.
- conversions numpy/float seconds ⇄ messages, one module per kind, each with its mapping table
  in its docstring: ``stamps`` (time, headers), ``covariance`` (the planar 6×6 covariances),
  ``odometry`` (tracks, reports, poses), ``clouds`` (tables as PointCloud2), ``diagnostics``,
  ``markers.ellipses`` (2σ ellipses), ``records.idsq`` (the IDSQ layout and handoff),
  ``track_arrays`` (a source's tracks as ``track_msgs/TrackArray``). Nodes call
  them in callbacks (no Node needed); the readers only extract numbers (even NaNs): ``validate``
  says whether a message is usable.
- ``validate``: reasons (``str | None``) why an incoming message is unusable, monotonic stamps.
- ``tf``: the transform tree: /tf and /tf_static QoS (tf2_ros's), ``planar_transform`` and
  ``pose_transform`` with tf2's frame-id rules, ``BODY_FRAME_TOPICS`` (Odometry children that are frames).
"""
