"""The launcher (``python -m track_nodes.launch``), scenario files and ``ros2 launch`` support."""
