"""ros2 launch track_nodes idsq.launch.py [use_sim_time:=true] [record:=NAME]

Same nodes and parameters as ``python -m track_nodes.launch idsq`` (config/idsq.yaml): vehicle_sim
and one acoustic_sensor / doa_sensor node per sensor of the §5.1 field.
"""

from track_nodes.launch.ros2_launch import scenario_launch_description


def generate_launch_description():
    return scenario_launch_description('idsq')
