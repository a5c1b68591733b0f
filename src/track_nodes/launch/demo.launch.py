"""ros2 launch track_nodes demo.launch.py [use_sim_time:=true] [record:=NAME]

Same nodes and parameters as ``python -m track_nodes.launch demo`` (config/demo.yaml); needs a
full ROS 2 install for launch/launch_ros. Without them, use the launcher module.
"""

from track_nodes.launch.ros2_launch import scenario_launch_description


def generate_launch_description():
    return scenario_launch_description('demo')
