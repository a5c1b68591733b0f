"""ros2 launch track_nodes victoria_park.launch.py [use_sim_time:=true] [record:=NAME]

Same nodes and parameters as ``python -m track_nodes.launch victoria_park`` (config/victoria_park.yaml); needs a
full ROS 2 install for launch/launch_ros. Without them, use the launcher module.
"""

from track_nodes.launch.ros2_launch import scenario_launch_description


def generate_launch_description():
    return scenario_launch_description('victoria_park')
