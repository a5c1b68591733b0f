"""ros2 launch track_nodes sonar.launch.py [record:=NAME] [rate:=R] [epoch:=E] [duration:=S] [use_sim_time:=B]

What ``python -m track_nodes.launch sonar --processes`` runs (config/sonar.yaml): the smart target,
the simulated sonar and route (sonar_sim) and the sonar observer with its SS-PF; with the same /clock,
recording and summary at the end (track_nodes/launch/ros2_launch.py). Needs launch and launch_ros (a
ROS 2 install, or built from their jazzy sources); without them, use the launcher module.
"""

from track_nodes.launch.ros2_launch import scenario_launch_description


def generate_launch_description():
    return scenario_launch_description('sonar')
