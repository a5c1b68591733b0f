"""track_msgs_py: topic names, QoS profiles, conversions and validation for standard messages.

The only layer that knows both track_core types and ROS messages. Every topic uses a type
from common_interfaces, so ``ros2 topic echo``, rosbags and Foxglove read it without our code.
"""
