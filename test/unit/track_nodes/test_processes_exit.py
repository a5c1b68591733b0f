"""``--processes``: which child ends the run as a failure (``launch.processes.ended_early``), and how its end is
named (``exit_text``)."""

import signal
from types import SimpleNamespace

from track_nodes.launch.processes import ended_early, exit_text, failed_children


def child(code, executable='demo_tracker', label='demo_tracker', pid=41):
    return SimpleNamespace(returncode=code, executable=executable, label=label, pid=pid, poll=lambda: code)


def test_while_every_child_runs_nothing_ended():
    assert ended_early([child(None), child(None)]) is None


def test_a_player_done_with_its_bag_ends_the_run_normally_any_other_end_does_not():
    player, tracker = child(0, 'player', 'player'), child(0)
    assert ended_early([player, child(None)]) == []
    assert ended_early([child(1, 'player', 'player')]) != []
    assert ended_early([tracker, child(None)]) == [tracker]  # a clean exit 0 (SIGTERM to it alone) too


def test_an_early_end_is_one_line_with_name_code_signal_and_pid(capsys):
    killed = child(-signal.SIGKILL)
    assert exit_text(killed) == 'exited with code -9 (ended by SIGKILL)'
    assert failed_children([killed, child(-signal.SIGINT, pid=42)], early=[killed]) == [killed]
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1 and 'demo_tracker' in lines[0] and 'SIGKILL' in lines[0] and 'pid 41' in lines[0], lines
