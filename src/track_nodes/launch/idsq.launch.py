"""ros2 launch track_nodes idsq.launch.py [record:=NAME] [rate:=R] [epoch:=E] [duration:=S] [use_sim_time:=B]

What ``python -m track_nodes.launch idsq --processes`` runs (config/idsq.yaml): vehicle_sim (the truth,
the layout and every sensor's readings on /idsq/sensor_<id>/reading) and one acoustic_sensor /
doa_sensor node per sensor of the §5.1 field, which hears only its readings; with the same /clock, recording and
summary at the end (track_nodes/launch/ros2_launch.py). Needs launch and launch_ros (a ROS 2
install, or built from their jazzy sources); without them, use the launcher module.
"""

from track_nodes.launch.ros2_launch import scenario_launch_description


def generate_launch_description():
    return scenario_launch_description('idsq')
