"""The live Foxglove view: ``foxglove_bridge`` (``track-foxglove``) serves the ROS graph over the Foxglove WebSocket."""
