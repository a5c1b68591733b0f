"""``ros2 launch`` files equal the launcher, and a node stops cleanly under launch.

- The launch plan (``launch/ros2_launch.py``: the scenario's nodes, the clock node, the recorder, then the
  summary executable) run as processes the way launch_ros starts them gives the launcher's summary for
  the same seed and epoch, and every process exits 0.
- The stop signals ``ros2 launch`` sends a node at Ctrl-C (launch's ``ExecuteLocal`` with its defaults):
  the terminal's SIGINT, launch's own SIGINT (non-interactive launch), SIGTERM ``sigterm_timeout`` = 5 s
  later and SIGKILL 5 s after that, to the process still running. Launch says "process has died" for
  any exit code but 0: the installed executables must exit 0, with no traceback.
- Through launch's own ``LaunchService`` (built from the jazzy sources into a scratch prefix by
  ``launch_rig``, only where ``TRACK_LAUNCH_SOURCES`` names them; skipped otherwise, as on CI): the demo
  launch file records, prints the launcher's summary and exits 0 with no node "died", and a Ctrl-C of the
  launch process group (terminal and launch SIGINT) stops every node cleanly.
"""

from __future__ import annotations

import contextlib
import importlib.util
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import rclpy
import yaml
from diagnostic_msgs.msg import DiagnosticStatus

from track_msgs_py.records.ready import NodeReady
from track_msgs_py.topics import READY
from track_nodes.base.ready import WATCH_QOS
from track_nodes.launch.ros2_launch import Launched, defaults, plan
from track_nodes.launch.scenario import load_scenario

_spec = importlib.util.spec_from_file_location('launch_rig', Path(__file__).with_name('launch_rig.py'))
launch_rig = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(launch_rig)  # a test-support module beside this file (the suite imports by path)

pytestmark = pytest.mark.integration

EPOCH = '2026-01-01T00:00:00'
SIGTERM_TIMEOUT, SIGKILL_TIMEOUT = 5.0, 5.0  # launch's ExecuteLocal defaults [s]
DIED = 'process has died'


def command(launched: Launched, prefix: Path, where: Path) -> list[str]:
    """The command line launch_ros's Node runs for ``launched``: the installed executable, its arguments,
    ``--ros-args -r __node:=NAME`` and one ``--params-file`` per params entry (a dict as a temporary file)."""
    cmd = [str(prefix / 'lib/track_nodes' / launched.executable), *launched.arguments, '--ros-args']
    if launched.name:
        cmd += ['-r', f'__node:={launched.name}']
    for k, params in enumerate(launched.params):
        path = params
        if isinstance(params, dict):
            path = where / f'{launched.name or launched.executable}-{k}.yaml'
            path.write_text(yaml.safe_dump({'/**': {'ros__parameters': params}}))
        cmd += ['--params-file', str(path)]
    return cmd


def summary_of(stdout: str) -> list[str]:
    """The summary lines after its 'bag: PATH' line (the path differs between two runs) and its 'duration' line:
    the span of the bag's log times, the recorder's receipt on the node clock, which in another process can
    trail a message's stamp by a /clock step (in one process, lock-step, it never does). Every count, every
    metric and the picture's path come after it."""
    lines = stdout.splitlines()
    starts = [k for k, line in enumerate(lines) if line.startswith('bag: ')]
    assert starts, stdout
    assert lines[starts[-1] + 1].startswith('duration '), lines
    return lines[starts[-1] + 2:]


def launcher_summary(repo: Path, cwd: Path, env: dict, scenario: str, *args: str) -> list[str]:
    proc = subprocess.run([sys.executable, '-m', 'track_nodes.launch', scenario, '--record', 'launcher',
                           '--epoch', EPOCH, *args], cwd=cwd, env=env, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    return summary_of(proc.stdout)


def run_plan(scenario: str, values: dict[str, str], prefix: Path, cwd: Path, env: dict) -> tuple[list[str], str]:
    """Run the launch plan as launch would: the nodes, the recorder and the clock; at the clock's exit SIGINT
    the recorder, then the summary executable, then SIGINT the rest. → (summary lines, every process's stderr)."""
    p = plan(load_scenario(scenario), values)
    assert p.clock is not None and p.recorder is not None
    procs = {}
    for launched in [*p.nodes, p.recorder, p.clock]:
        procs[launched.name or launched.executable] = subprocess.Popen(
            command(launched, prefix, cwd), cwd=cwd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
            text=True)
    errs = {}
    try:
        errs['clock'] = procs['clock'].communicate(timeout=600)[1]
        assert procs['clock'].returncode == 0, errs['clock']
        procs['recorder'].send_signal(signal.SIGINT)
        errs['recorder'] = procs['recorder'].communicate(timeout=60)[1]
        assert procs['recorder'].returncode == 0, errs['recorder']
        summary = subprocess.run([str(prefix / 'lib/track_nodes/summary'), *p.summary], cwd=cwd, env=env,
                                 capture_output=True, text=True, timeout=300)
        assert summary.returncode == 0, summary.stderr
        for proc in procs.values():
            if proc.poll() is None:
                proc.send_signal(signal.SIGINT)
        for name, proc in procs.items():
            errs[name] = errs.get(name) or proc.communicate(timeout=60)[1]
            assert proc.returncode == 0, f'{name}: exit {proc.returncode}: {errs[name]}'
    finally:
        for proc in procs.values():
            proc.kill()
    return summary_of(summary.stdout), '\n'.join(errs.values())


def test_the_launch_defaults_are_the_launchers(repo):
    maritime, demo, park = (load_scenario(s) for s in ('maritime', 'demo', 'victoria_park'))
    assert defaults(maritime) == {'use_sim_time': 'true', 'rate': '20', 'epoch': 'now', 'duration': '32',
                                 'record': '', 'one_process_per_sensor': 'false'}
    assert defaults(demo)['rate'] == '10' and defaults(demo)['use_sim_time'] == 'true'
    p = plan(park, {})
    assert defaults(park)['use_sim_time'] == 'false'  # the player publishes /clock
    assert p.wall_duration == 320.0  # the bound; the end is the clock node's, once the bag is played:
    assert p.clock.params[0]['end_after'] == 'player' and 'rate' not in p.clock.params[0]
    assert p.clock_done == 'the bag has been played'


def test_a_replays_clock_node_publishes_no_clock_and_ends_once_the_player_has_left(ros):
    """victoria_park under ros2 launch: the clock node (end_after) waits for the player to be up, publishes no
    /clock (the player's is the bag's), and exits 0 once the player has left the graph and the graph is quiet,
    not after the scenario's whole duration."""
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.parameter import Parameter
    from rosgraph_msgs.msg import Clock

    from track_msgs_py.qos import CLOCK_QOS
    from track_nodes.demo.demo_target import DemoTargetNode
    from track_nodes.launch.clock import ClockNode, Phase

    ticks = []
    ros.add(rclpy.create_node('clock_listener', context=ros.context)).create_subscription(
        Clock, '/clock', ticks.append, CLOCK_QOS)
    player = DemoTargetNode(node_name='player', context=ros.context)  # stands for the player: announces, leaves
    ros.executor.add_node(player)
    own = Context()
    rclpy.init(context=own, domain_id=ros.domain_id)
    executor = SingleThreadedExecutor(context=own)
    clock = ClockNode(context=own, parameter_overrides=[Parameter('wait_for', value='player'),
                                                        Parameter('end_after', value='player')])
    executor.add_node(clock)

    def spin(predicate):
        def step() -> bool:
            if own.ok():
                executor.spin_once(timeout_sec=0.01)
            return predicate()
        return ros.spin_until(step, timeout=120)

    try:
        assert spin(lambda: clock.phase is Phase.FOLLOWING), clock.phase
        assert own.ok() and clock.clock_pub.get_subscription_count() >= 1
        ros.executor.remove_node(player)
        player.destroy_node()
        assert spin(lambda: not own.ok()), clock.phase  # drained, done: the context shut down (exit 0)
        assert clock.exit_code == 0 and not ticks, ticks
    finally:
        executor.shutdown()
        clock.destroy_node()
        own.try_shutdown()


def test_a_cut_run_or_a_node_that_fails_ends_the_launch_with_a_reason(tmp_path):
    """The summary gets the run's duration (a run whose /clock stopped earlier is CUT, exit 1, and launch exits
    1); a node that exits with an error stops the run (its data missing); the recorder drops an empty bag."""
    from track_nodes.launch.ros2_launch import stopping_reason, summary_problem

    p = plan(load_scenario('demo'), {'record': str(tmp_path / 'bag'), 'duration': '36'})
    assert p.summary[-2:] == ['--duration', '36'] and p.recorder.params[0]['discard_empty'] is True
    assert '--duration' not in plan(load_scenario('victoria_park'), {'record': str(tmp_path / 'park')}).summary
    assert summary_problem(0) is None and 'cut' in summary_problem(1) and 'exit code 2' in summary_problem(2)
    assert stopping_reason('ais_source-1', 2, False) == 'ais_source-1 exited with code 2: stopping the run'
    assert stopping_reason('ais_source-1', 2, True) is None  # launch's own shutdown (Ctrl-C)
    assert stopping_reason('player-1', 0, False) is None  # a played bag: the clock node ends the run


def test_the_plan_groups_the_sensors_and_clocks_every_node(tmp_path):
    sc = load_scenario('maritime')
    p = plan(sc, {'record': str(tmp_path / 'bag'), 'epoch': EPOCH})
    group = [n for n in p.nodes if n.executable == 'node_group']
    assert len(group) == 1 and len(group[0].arguments) == 41  # --nodes and the 40 sensors
    assert p.clock.params[0]['wait_for'].split(',') == [s.name for s in sc.nodes]
    assert p.clock.params[0]['record_regex'] == sc.options['record_regex']
    assert p.summary == [str(tmp_path / 'bag'), '--scenario', 'maritime', '--duration', '32']
    (tmp_path / 'bag').mkdir()
    with pytest.raises(RuntimeError, match='exists already'):
        plan(sc, {'record': str(tmp_path / 'bag')})
    with pytest.raises(ValueError, match='epoch'):
        plan(sc, {'epoch': 'yesterday'})


def test_the_launch_plan_gives_the_launchers_summary(repo, prefix, tmp_path, env_factory):
    """demo, seed 7, 4 s at 20x from the same epoch: the launch plan's processes (the clock node holding the
    epoch until every node is up) and the launcher (one process, lock-step) summarise the same."""
    values = {'record': 'planned', 'duration': '4', 'rate': '20', 'epoch': EPOCH}
    planned, errs = run_plan('demo', values, prefix, tmp_path, env_factory())
    assert 'Traceback' not in errs and 'refused' not in errs, errs
    assert planned == launcher_summary(repo, tmp_path, env_factory(), 'demo', '--duration', '4', '--rate', '20')
    assert any('position RMSE' in line for line in planned), planned


def test_the_maritime_launch_plan_gives_the_launchers_summary(repo, prefix, tmp_path, env_factory):
    """maritime, 8 s at 20x from the same epoch: the sonar, the network of 40 sensors in their group process,
    the radar and the fusion node each in a process of their own score the instants a lock-step run scores
    (the fusion node's stamp schedule waits for every input topic's watermark), so the summaries agree."""
    values = {'record': 'planned', 'duration': '8', 'epoch': EPOCH}
    planned, errs = run_plan('maritime', values, prefix, tmp_path, env_factory())
    assert 'Traceback' not in errs and 'refused' not in errs, errs
    ref = launcher_summary(repo, tmp_path, env_factory(), 'maritime', '--duration', '8')
    assert [line.replace('/planned/', '/BAG/') for line in planned] == [line.replace('/launcher/', '/BAG/')
                                                                        for line in ref]
    assert any(line.startswith('true pair (sonar | network)') for line in planned), planned


def test_the_clock_node_refuses_sim_time_and_a_bad_epoch(prefix, env_factory):
    clock = str(prefix / 'lib/track_nodes/clock')
    for setting, word in (('use_sim_time:=true', 'use_sim_time'), ('epoch:=yesterday', 'epoch')):
        proc = subprocess.run([clock, '--ros-args', '-p', setting], env=env_factory(), capture_output=True, text=True,
                              timeout=120)
        assert proc.returncode == 2 and word in proc.stderr and 'Traceback' not in proc.stderr, proc.stderr
        assert len(proc.stderr.strip().splitlines()) == 1, proc.stderr


# --- the stop signals of ros2 launch --------------------------------------------------------------

def stop_as_launch_does(proc: subprocess.Popen, gap: float) -> list[str]:
    """At Ctrl-C: the terminal's SIGINT, launch's own ``gap`` s later, SIGTERM at 5 s and SIGKILL at 10 s to a
    process still running (launch's ExecuteLocal timers). → the signals sent."""
    sent, t0 = [], time.monotonic()
    plan_ = [(0.0, signal.SIGINT), (gap, signal.SIGINT), (SIGTERM_TIMEOUT, signal.SIGTERM),
             (SIGTERM_TIMEOUT + SIGKILL_TIMEOUT, signal.SIGKILL)]
    for at, sig in plan_:
        while proc.poll() is None and time.monotonic() - t0 < at:
            time.sleep(0.005)
        if proc.poll() is not None:
            break
        proc.send_signal(sig)
        sent.append(sig.name)
    proc.wait(timeout=60)
    return sent


@pytest.mark.parametrize(('executable', 'args', 'gap'), [
    ('demo_tracker', [], 0.0), ('demo_tracker', [], 0.02), ('demo_tracker', [], 0.2),
    ('node_group', ['--nodes', 'demo_target:t1', 'demo_tracker:t2'], 0.02),
    ('clock', [], 0.02),
])
def test_a_node_stops_cleanly_on_the_signals_of_ros2_launch(prefix, ros, executable, args, gap):
    """A real installed executable, up (announced on /track/ready): SIGINT, SIGINT again ``gap`` s later, and
    SIGTERM only if it is still running 5 s on; it exits 0 (launch: "finished cleanly"), no traceback."""
    up: set[str] = set()
    watcher = ros.add(rclpy.create_node('ready_watch', context=ros.context))
    watcher.create_subscription(DiagnosticStatus, READY, lambda m: up.add(NodeReady.from_msg(m).name), WATCH_QOS)
    names = {'/' + a.split(':')[1] for a in args[1:]} or {f'/{executable}'}
    proc = subprocess.Popen([str(prefix / 'lib/track_nodes' / executable), *args], env=ros.env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        assert ros.spin_until(lambda: names <= up, timeout=120), f'{names} not up'
        sent = stop_as_launch_does(proc, gap)
        err = proc.stderr.read()
    finally:
        proc.kill()
    assert proc.returncode == 0, f'exit {proc.returncode} after {sent}: {err}'
    assert sent[:2] == ['SIGINT', 'SIGINT'] or len(sent) == 1, sent  # it may be gone before the second
    assert 'SIGKILL' not in sent and 'Traceback' not in err and 'KeyboardInterrupt' not in err, (sent, err)


# --- through launch's LaunchService ---------------------------------------------------------------

DRIVER = '''
import sys
from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription, LaunchService
from launch.actions import IncludeLaunchDescription
from launch.launch_description_sources import PythonLaunchDescriptionSource
path = f"{get_package_share_directory('track_nodes')}/launch/{sys.argv[1]}.launch.py"
service = LaunchService(noninteractive=True)  # launch sends its own SIGINT at Ctrl-C
service.include_launch_description(LaunchDescription([IncludeLaunchDescription(
    PythonLaunchDescriptionSource(path), launch_arguments=[a.split(':=', 1) for a in sys.argv[2:]])]))
sys.exit(service.run())
'''


@pytest.fixture(scope='module')
def launch_env(tmp_path_factory):
    root = launch_rig.sources()
    if root is None:
        pytest.skip(launch_rig.skip_reason())
    return launch_rig.build(root, tmp_path_factory.mktemp('launch_build'))


def run_launch(launch_env: dict, cwd: Path, scenario: str, *args: str, **popen) -> subprocess.Popen:
    env = {**launch_env, 'ROS_DOMAIN_ID': popen.pop('domain'), 'ROS_LOG_DIR': str(cwd / 'log')}
    return subprocess.Popen([sys.executable, '-c', DRIVER, scenario, *args], cwd=cwd, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, **popen)


def test_launch_service_runs_demo_like_the_launcher(launch_env, repo, tmp_path, env_factory):
    env = env_factory()
    proc = run_launch(launch_env, tmp_path, 'demo', 'record:=launched', 'duration:=4', 'rate:=20', f'epoch:={EPOCH}',
                      domain=env['ROS_DOMAIN_ID'])
    out = proc.communicate(timeout=600)[0]
    assert proc.returncode == 0, out
    assert DIED not in out and 'Traceback' not in out and 'refused' not in out, out
    assert '[summary-' in out and 'process has finished cleanly' in out, out
    launched = [line.split('] ', 1)[1] for line in out.splitlines() if line.startswith('[summary-')]
    assert summary_of('\n'.join(launched)) == launcher_summary(repo, tmp_path, env, 'demo', '--duration', '4',
                                                               '--rate', '20')


def test_launch_service_runs_maritime_like_the_launcher(launch_env, repo, tmp_path, env_factory):
    """The walk-through ``ros2 launch track_nodes maritime.launch.py``, 8 s from the same epoch: the launcher's
    summary, line for line (the picture's path aside)."""
    env = env_factory()
    proc = run_launch(launch_env, tmp_path, 'maritime', 'record:=launched', 'duration:=8', f'epoch:={EPOCH}',
                      domain=env['ROS_DOMAIN_ID'])
    out = proc.communicate(timeout=900)[0]
    assert proc.returncode == 0, out
    assert DIED not in out and 'Traceback' not in out, out
    launched = [line.split('] ', 1)[1] for line in out.splitlines() if line.startswith('[summary-')]
    ref = launcher_summary(repo, tmp_path, env, 'maritime', '--duration', '8')
    assert [x.replace('/launched/', '/BAG/') for x in summary_of('\n'.join(launched))] == [
        x.replace('/launcher/', '/BAG/') for x in ref]


def test_ctrl_c_of_ros2_launch_reports_no_node_died(launch_env, tmp_path, env_factory):
    """The terminal's SIGINT to the whole process group (launch and its nodes), launch's own SIGINT after it."""
    env = env_factory()
    proc = run_launch(launch_env, tmp_path, 'demo', 'record:=stopped', 'duration:=0', domain=env['ROS_DOMAIN_ID'],
                      start_new_session=True)
    lines: list[str] = []
    try:
        deadline = time.monotonic() + 300
        while time.monotonic() < deadline and not any('/clock running' in line for line in lines):
            line = proc.stdout.readline()
            if not line:
                break
            lines.append(line)
        assert any('/clock running' in line for line in lines), ''.join(lines)
        os.killpg(proc.pid, signal.SIGINT)
        out = ''.join(lines) + proc.communicate(timeout=120)[0]
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)
    assert proc.returncode == 0, out
    assert DIED not in out and 'Traceback' not in out and 'SIGTERM' not in out, out
    assert out.count('process has finished cleanly') == 4, out  # demo_target, demo_tracker, recorder, clock
    assert (tmp_path / 'bags/stopped/metadata.yaml').is_file()
