"""``ros2 launch`` support for users with a full ROS 2 install (launch/launch_ros are not on PyPI).

``launch/<scenario>.launch.py`` calls ``scenario_launch_description('<scenario>')``, which reads
the same ``config/<scenario>.yaml`` as ``python -m track_nodes.launch`` and starts one
``launch_ros`` Node per entry of its ``track_launch.nodes``. Launch arguments:
``use_sim_time`` (default false), ``record`` (a bag name; empty = no recording) and
``one_process_per_sensor`` (default false: the IDSQ sensors of the scenario run as one
``node_group`` process, so a 40-sensor field comes up on a 2-core machine; true: one process each,
as on a real distributed field).
"""

from __future__ import annotations

from track_nodes.launch.scenario import load_scenario

GROUPED = frozenset({'acoustic_sensor', 'doa_sensor'})  # executables hosted by one node_group


def scenario_launch_description(scenario_name: str):
    from launch import LaunchDescription
    from launch.actions import DeclareLaunchArgument
    from launch.conditions import IfCondition, UnlessCondition
    from launch.substitutions import LaunchConfiguration, PythonExpression
    from launch_ros.actions import Node

    sc = load_scenario(scenario_name)
    sim = LaunchConfiguration('use_sim_time')
    record = LaunchConfiguration('record')
    actions = [
        DeclareLaunchArgument('use_sim_time', default_value='false', description='follow /clock'),
        DeclareLaunchArgument('record', default_value='', description='record to bags/<record>/'),
        DeclareLaunchArgument('one_process_per_sensor', default_value='false',
                              description='IDSQ sensors: one process each (true) or one node_group (false)'),
    ]
    each = LaunchConfiguration('one_process_per_sensor')
    grouped = [spec for spec in sc.nodes if spec.executable in GROUPED]
    for spec in sc.nodes:
        actions.append(Node(package='track_nodes', executable=spec.executable, name=spec.name,
                            parameters=[str(sc.path), {'use_sim_time': sim}], output='screen',
                            condition=IfCondition(each) if spec in grouped else None))
    if grouped:  # no name= here: it would rename every node of the group
        actions.append(Node(package='track_nodes', executable='node_group', output='screen',
                            arguments=['--nodes', *[f'{s.executable}:{s.name}' for s in grouped]],
                            parameters=[str(sc.path), {'use_sim_time': sim}], condition=UnlessCondition(each)))
    actions.append(Node(
        package='track_nodes', executable='recorder', name='recorder', output='screen',
        parameters=[{'use_sim_time': sim, 'bag': record,
                     'regex': str(sc.options.get('record_regex', '.*'))}],
        condition=IfCondition(PythonExpression(["'", record, "' != ''"]))))
    return LaunchDescription(actions)
