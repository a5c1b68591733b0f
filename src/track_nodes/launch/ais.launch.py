"""ros2 launch track_nodes ais.launch.py [use_sim_time:=true] [record:=NAME]

Same nodes and parameters as ``python -m track_nodes.launch ais`` (config/ais.yaml).
"""

from track_nodes.launch.ros2_launch import scenario_launch_description


def generate_launch_description():
    return scenario_launch_description('ais')
