"""track_nodes: the rclpy layer: nodes, bag tools, the launcher and the reports.

Sub-packages by role; imports point down only (the layering test enforces it):

| package | what |
|---|---|
| ``base/`` | ``TrackNode`` (constructor, parameters, ``main``), ``Param``, ``FixedRateSteps``, CLI parsing |
| ``demo/`` ``sonar/`` ``idsq/`` ``rfid/`` ``slam/`` ``fusion/`` | estimators, and the simulators feeding them |
| ``bag/`` | recorder, player, recovery of killed recordings, dataset conversion (``api`` is what they share) |
| ``launch/`` | the launcher (``python -m track_nodes.launch``), scenario files and their generators, ``ros2 launch`` |
| ``report/`` | one-screen summaries and pictures of recorded bags, one module per scenario |

``registry.NODES`` maps every executable to its class; ``python -m track_nodes EXE`` (what the
``ros2 run`` shims call) runs it. A node declares its parameters, builds its track_core object,
and in callbacks does validate → from_msg → core step → to_msg → publish. No estimation maths
and no state machine lives here, and no node module imports another.
"""
