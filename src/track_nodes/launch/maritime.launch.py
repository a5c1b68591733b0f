"""ros2 launch track_nodes maritime.launch.py [record:=NAME] [rate:=R] [epoch:=E] [duration:=S] [use_sim_time:=B]

What ``python -m track_nodes.launch maritime --processes`` runs (config/maritime.yaml): the smart
target and the sonar observer, the IDSQ sensor field (vehicle_sim reads the target's and the decoy's
truths and publishes every sensor's readings), the coastal radar with the decoy, and the
fusion node; with the same /clock, recording and summary at the end
(track_nodes/launch/ros2_launch.py). Needs launch and launch_ros (a ROS 2 install, or built from
their jazzy sources); without them, use the launcher module.
"""

from track_nodes.launch.ros2_launch import scenario_launch_description


def generate_launch_description():
    return scenario_launch_description('maritime')
