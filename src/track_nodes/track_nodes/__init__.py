"""track_nodes: rclpy nodes, the recorder, the player and the launcher.

A node declares its parameters, builds its track_core object, and in callbacks does
``from_msg → core step → to_msg → publish``. No estimation maths lives here.
"""
