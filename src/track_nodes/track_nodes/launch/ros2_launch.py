"""``ros2 launch`` support for users with a full ROS 2 install (launch/launch_ros are not on PyPI).

``launch/<scenario>.launch.py`` calls ``scenario_launch_description('<scenario>')``, which reads
the same ``config/<scenario>.yaml`` as ``python -m track_nodes.launch`` and starts one
``launch_ros`` Node per entry of its ``track_launch.nodes``. Launch arguments:
``use_sim_time`` (default false) and ``record`` (a bag name; empty = no recording).
"""

from __future__ import annotations

from track_nodes.launch.scenario import load_scenario


def scenario_launch_description(scenario_name: str):
    from launch import LaunchDescription
    from launch.actions import DeclareLaunchArgument
    from launch.conditions import IfCondition
    from launch.substitutions import LaunchConfiguration, PythonExpression
    from launch_ros.actions import Node

    sc = load_scenario(scenario_name)
    sim = LaunchConfiguration('use_sim_time')
    record = LaunchConfiguration('record')
    actions = [
        DeclareLaunchArgument('use_sim_time', default_value='false', description='follow /clock'),
        DeclareLaunchArgument('record', default_value='', description='record to bags/<record>/'),
    ]
    for spec in sc.nodes:
        actions.append(Node(package='track_nodes', executable=spec.executable, name=spec.name,
                            parameters=[str(sc.path), {'use_sim_time': sim}], output='screen'))
    actions.append(Node(
        package='track_nodes', executable='recorder', name='recorder', output='screen',
        parameters=[{'use_sim_time': sim, 'bag': record,
                     'regex': str(sc.options.get('record_regex', '.*'))}],
        condition=IfCondition(PythonExpression(["'", record, "' != ''"]))))
    return LaunchDescription(actions)
