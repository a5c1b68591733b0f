"""ros2 launch track_nodes ais_live.launch.py [record:=NAME] [rate:=R] [epoch:=E] [duration:=S] [use_sim_time:=B]

What ``python -m track_nodes.launch ais_live --processes`` runs (config/ais_live.yaml); with the same /clock,
recording and summary at the end (track_nodes/launch/ros2_launch.py). Needs launch and launch_ros (a
ROS 2 install, or built from their jazzy sources); without them, use the launcher module.
"""

from track_nodes.launch.ros2_launch import scenario_launch_description


def generate_launch_description():
    return scenario_launch_description('ais_live')
