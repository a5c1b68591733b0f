"""``ros2 launch`` support for users with a full ROS 2 install (launch/launch_ros are not on PyPI).

``launch/<scenario>.launch.py`` calls ``scenario_launch_description('<scenario>')``, which reads
the same ``config/<scenario>.yaml`` as ``python -m track_nodes.launch`` and runs what the launcher
runs with one process per node (``--processes``):

- one ``launch_ros`` Node per entry of its ``track_launch.nodes``, with ``use_sim_time``;
- under ``use_sim_time`` (the default) the ``clock`` node (``launch/clock.py``): /clock at ``rate``
  × real time from ``epoch`` until ``duration``, started once every node is up and held at the epoch
  while discovery settles (every node's step origin is the epoch). A scenario whose ``player``
  publishes /clock runs on wall time; its clock node then exits once the bag is played and the
  recorded topics are quiet;
- with ``record:=NAME`` the recorder (``bags/NAME/``, the scenario's ``record_regex``);
- the end: when the clock node exits (on wall time, after ``duration``) the recorder gets SIGINT and
  closes its bag, the ``summary`` executable prints the launcher's summary (a run whose /clock
  stopped before ``duration`` is CUT: launch exits 1), and launch shuts every node down;
- a node process that exits with an error stops the run at once; ``discard_empty`` removes an empty
  bag. In full: docs/MODULES.md, "ros2 launch in full".

Launch arguments: ``use_sim_time`` (default true), ``rate`` (default the scenario's, 1.0 where it has
none), ``epoch`` (default ``now``), ``duration`` (node seconds, default the scenario's; 0 runs until
Ctrl-C), ``record`` (a bag name; empty = no recording) and ``one_process_per_sensor`` (default
false: the IDSQ sensors of the scenario run as one ``node_group`` process, so a 40-sensor field
comes up on a 2-core machine; true: one process each, as on a real distributed field).
"""

from __future__ import annotations

import signal
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from track_nodes.base.epoch import parse_epoch
from track_nodes.launch.scenario import Scenario, load_scenario

GROUPED = frozenset({'acoustic_sensor', 'doa_sensor'})  # executables hosted by one node_group
TRUE = ('true', '1', 'yes', 'on')


def bag_path(record: str) -> Path:
    """Where the recorder writes ``record`` (``bag`` parameter: a name → bags/NAME, a path with '/')."""
    return Path(record) if '/' in record else Path('bags') / record


def defaults(sc: Scenario) -> dict[str, str]:
    """The launch arguments' defaults for scenario ``sc`` (the launcher's: its ``rate`` and ``duration``)."""
    player = any(spec.executable == 'player' for spec in sc.nodes)  # /clock from a bag
    rate = float(sc.options.get('rate', 0.0) or 0.0)
    return {'use_sim_time': 'false' if player else 'true', 'rate': f'{rate if rate > 0 else 1.0:g}',
            'epoch': 'now', 'duration': f'{float(sc.options.get("duration", 0.0) or 0.0):g}', 'record': '',
            'one_process_per_sensor': 'false'}


DESCRIPTIONS = {
    'use_sim_time': 'every node follows /clock (the clock node drives it)',
    'rate': '/clock speed (x real time)',
    'epoch': "node time at which /clock starts: 'now', whole seconds since 1970, or an ISO date (UTC)",
    'duration': 'run length [s of node time; wall s without use_sim_time]; 0 = until Ctrl-C',
    'record': 'record to bags/<record>/ (a name) or to a path; empty = no recording',
    'one_process_per_sensor': 'IDSQ sensors: one process each (true) or one node_group (false)',
}


@dataclass
class Launched:
    """One process of the launch: ``ros2 run track_nodes <executable> <arguments> --ros-args -r __node:=<name>``
    with ``params`` (params files and dicts, in order)."""

    executable: str
    name: str | None
    params: list = field(default_factory=list)
    arguments: list[str] = field(default_factory=list)


@dataclass
class Plan:
    """What a launch of a scenario runs, for given launch-argument values (``plan``)."""

    nodes: list[Launched]
    recorder: Launched | None = None
    clock: Launched | None = None
    bag: Path | None = None
    summary: list[str] | None = None  # the summary executable's arguments, after the recording
    wall_duration: float = 0.0  # on wall time: end after this many wall seconds (0: never)
    clock_done: str = '/clock done'  # what the clock node's exit means


def plan(sc: Scenario, values: Mapping[str, str]) -> Plan:
    """The processes of scenario ``sc`` for the launch arguments ``values`` (``defaults`` fill the rest);
    ValueError for a bad value, RuntimeError for a bag that exists."""
    arg = {**defaults(sc), **values}
    sim = arg['use_sim_time'].strip().lower() in TRUE
    record = arg['record'].strip()
    duration, rate = float(arg['duration']), float(arg['rate'])
    if not (duration >= 0 and rate > 0):
        raise ValueError(f'duration:={arg["duration"]} must be >= 0 and rate:={arg["rate"]} > 0')
    parse_epoch(arg['epoch'], 'epoch:=')  # a bad epoch is one line before anything starts
    regex = str(sc.options.get('record_regex', '.*'))
    bag = bag_path(record) if record else None
    if bag is not None and bag.exists():
        raise RuntimeError(f'record:={record}: {bag} exists already, not overwriting (choose another name)')
    player = any(spec.executable == 'player' for spec in sc.nodes)
    grouped = [spec for spec in sc.nodes if spec.executable in GROUPED]
    each = arg['one_process_per_sensor'].strip().lower() in TRUE
    params = [str(sc.path), {'use_sim_time': sim}]
    out = Plan([Launched(spec.executable, spec.name, params) for spec in sc.nodes if each or spec not in grouped])
    if grouped and not each:  # no name: it would rename every node of the group
        out.nodes.append(Launched('node_group', None, params, ['--nodes', *[f'{s.executable}:{s.name}'
                                                                            for s in grouped]]))
    if bag is not None:
        out.bag = bag
        out.recorder = Launched('recorder', 'recorder', [{'use_sim_time': sim, 'bag': str(bag), 'regex': regex,
                                                          'discard_empty': True}])
        out.summary = [str(bag), *(['--scenario', str(sc.options['summary'])] if sc.options.get('summary') else [])]
        if sim and not player and duration > 0:  # a run whose /clock stopped earlier is marked cut, exit 1
            out.summary += ['--duration', f'{duration:g}']
    wait_for = ','.join(spec.name for spec in sc.nodes)
    if sim and not player:
        out.clock = Launched('clock', 'clock', [{
            'use_sim_time': False, 'rate': rate, 'epoch': arg['epoch'], 'duration': duration,
            'wait_for': wait_for, 'record_regex': regex if bag else ''}])
        return out
    out.wall_duration = duration
    players = [spec.name for spec in sc.nodes if spec.executable == 'player']
    if players:  # a replay ends when its bag is played (a looped one never leaves: duration ends it)
        out.clock = Launched('clock', 'clock', [{'use_sim_time': False, 'wait_for': wait_for,
                                                 'end_after': ','.join(players), 'record_regex': regex if bag else ''}])
        out.clock_done = 'the bag has been played'
    return out


class RunCutError(RuntimeError):
    """The summary says the run did not reach its duration (a stop that reached only the clock node)."""


def summary_problem(returncode: int) -> str | None:
    """What the summary executable's exit code says about the run: None for a complete one."""
    if returncode == 0:
        return None
    if returncode == 1:  # report.summary.EXIT_CUT
        return 'the run was cut before its duration (see the summary\'s CUT line)'
    return f'the summary failed (exit code {returncode})'


def stopping_reason(name: str, returncode: int | None, shutting_down: bool) -> str | None:
    """Why the run stops when the node process ``name`` exits with ``returncode``; None: it goes on.

    A node that exits 0 on its own (a played bag) is the clock node's business; during launch's own
    shutdown (Ctrl-C) every exit is expected."""
    if shutting_down or returncode in (0, None):
        return None
    return f'{name} exited with code {returncode}: stopping the run'


def scenario_launch_description(scenario_name: str):
    from launch import LaunchDescription
    from launch.actions import DeclareLaunchArgument, OpaqueFunction

    sc = load_scenario(scenario_name)
    args = [DeclareLaunchArgument(name, default_value=value, description=DESCRIPTIONS[name])
            for name, value in defaults(sc).items()]
    return LaunchDescription([*args, OpaqueFunction(function=_actions, args=[sc])])


def _actions(context, sc: Scenario) -> list:
    """The launch actions of ``plan`` for the launch arguments' values in ``context``."""
    from launch.actions import EmitEvent, ExecuteProcess, LogInfo, RegisterEventHandler, TimerAction
    from launch.event_handlers import OnProcessExit
    from launch.events import Shutdown
    from launch.events.process import SignalProcess
    from launch_ros.actions import Node
    from launch_ros.substitutions import ExecutableInPackage

    p = plan(sc, {name: context.launch_configurations[name] for name in DESCRIPTIONS})

    def node(launched: Launched):
        named = {'name': launched.name} if launched.name else {}
        return Node(package='track_nodes', executable=launched.executable, parameters=launched.params,
                    arguments=launched.arguments, output='screen', **named)

    actions = [node(n) for n in p.nodes]
    recorder = node(p.recorder) if p.recorder else None

    def died(event, ctx) -> list:
        """A node that ends with an error before the run's end (its data missing: one line of its own)
        ends the run, instead of a run and a recording going on without it."""
        if (reason := stopping_reason(event.name, event.returncode, ctx.is_shutdown)) is None:
            return []
        return [LogInfo(msg=reason), EmitEvent(event=Shutdown(reason=reason))]

    actions += [RegisterEventHandler(OnProcessExit(target_action=a, on_exit=died)) for a in list(actions)]

    def end(reason: str) -> list:
        """Stop the recorder (its exit runs the summary), else shut down."""
        if recorder is None:
            return [EmitEvent(event=Shutdown(reason=reason))]
        return [LogInfo(msg=f'{reason}: stopping the recorder'),
                EmitEvent(event=SignalProcess(signal_number=signal.SIGINT, process_matcher=lambda a: a is recorder))]

    if recorder is not None:
        summary = [ExecutableInPackage('summary', 'track_nodes'), *p.summary]

        def summarize(event, ctx) -> list:
            if ctx.is_shutdown:  # Ctrl-C: launch starts no new process now
                if not (p.bag / 'metadata.yaml').is_file():  # nothing recorded: the recorder removed it
                    return [LogInfo(msg=f'no bag: nothing was recorded to {p.bag}')]
                return [LogInfo(msg=f'bag closed: {p.bag}; its summary: ros2 run track_nodes summary '
                                    f'{" ".join(p.summary)}')]
            return [ExecuteProcess(cmd=summary, name='summary', output='screen', on_exit=finished)]

        def finished(event, ctx) -> list:
            if (problem := summary_problem(event.returncode)) is not None:
                raise RunCutError(problem)  # launch: "Caught exception in launch: ...", shuts down, exit code 1
            return [EmitEvent(event=Shutdown(reason='run done'))]

        actions += [recorder, RegisterEventHandler(OnProcessExit(target_action=recorder, on_exit=summarize))]
    if p.clock is not None:
        clock = node(p.clock)
        actions += [clock, RegisterEventHandler(OnProcessExit(
            target_action=clock, on_exit=lambda event, ctx: end(f'{p.clock_done} (exit code {event.returncode})')))]
    if p.wall_duration > 0:
        actions.append(TimerAction(period=p.wall_duration, actions=end(f'{p.wall_duration:g} s of wall time')))
    return actions
