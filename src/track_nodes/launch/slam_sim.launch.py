"""ros2 launch track_nodes slam_sim.launch.py [use_sim_time:=true] [record:=NAME]

Same nodes and parameters as ``python -m track_nodes.launch slam_sim`` (config/slam_sim.yaml); needs a
full ROS 2 install for launch/launch_ros. Without them, use the launcher module.
"""

from track_nodes.launch.ros2_launch import scenario_launch_description


def generate_launch_description():
    return scenario_launch_description('slam_sim')
