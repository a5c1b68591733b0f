"""ros2 launch track_nodes maritime.launch.py [use_sim_time:=true] [record:=NAME]

Same nodes and parameters as ``python -m track_nodes.launch maritime`` (config/maritime.yaml): the
smart target and the sonar observer, the IDSQ sensor field, the coastal radar with the decoy, and
the fusion node (track_nodes/maritime.py).
"""

from track_nodes.launch.ros2_launch import scenario_launch_description


def generate_launch_description():
    return scenario_launch_description('maritime')
