"""Summary of the rfid scenario: found or not, steps, turns, distance."""

from __future__ import annotations

from pathlib import Path

from track_nodes.report.read import read_topics


def rfid_metrics(bag: Path) -> list[str]:
    """RFID scenario: found or not, steps, turns, distance walked and the final distance to the tag.

    From the reader's truth status (``/rfid/user/status``, the last one: steps = MOVEs walked with
    repeated ones, turns = rotations made including the initial search for the signal and detours),
    the ``/rfid/found`` event and the commands (``/rfid/command``, counted once per seq: re-sent
    copies are not new commands).
    """
    from track_core.rfid.protocol import CommandKind
    from track_msgs_py.records import RecordError
    from track_msgs_py.records.rfid import RfidCommand, RfidUserStatus
    from track_msgs_py.topics import RFID_COMMAND, RFID_FOUND, RFID_USER_STATUS

    msgs = read_topics(bag, {RFID_COMMAND, RFID_FOUND, RFID_USER_STATUS})
    status = [RfidUserStatus.from_msg(m) for m in msgs.get(RFID_USER_STATUS, [])]
    if not status:
        return ['rfid: no user status recorded']
    last = status[-1]
    commands: dict[int, RfidCommand] = {}
    for m in msgs.get(RFID_COMMAND, []):
        try:
            c = RfidCommand.from_msg(m)
        except RecordError:
            continue  # not one the guidance sent (a fuzzer's, say): no command of the search
        commands.setdefault(c.seq, c)
    kinds = [c.kind for _, c in sorted(commands.items())]
    done = [c for c in commands.values() if c.kind is CommandKind.DONE]
    found = bool(msgs.get(RFID_FOUND)) or last.found
    if found:
        verdict = 'tag FOUND'
    elif done:
        verdict = f'tag NOT found ({done[-1].reason})'
    else:
        verdict = 'tag NOT found (the search was still running when the recording stopped)'
    repeats = sum(c.repeat for c in commands.values())
    return [
        f'rfid: {verdict}',
        f'  steps {last.steps}, turns {last.turns}, distance walked {last.distance_m:.2f} m, '
        f'final distance to the tag {last.distance_to_tag_m:.3f} m',
        f'  commands {len(commands)} (MOVE {kinds.count(CommandKind.MOVE)}, TURN {kinds.count(CommandKind.TURN)}), '
        f'repeated steps {repeats}, steps undone by the user {last.repeats}',
    ]
