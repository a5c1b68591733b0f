"""track_core.rfid.log: the CSV layout read and written, the shipped example, and every refusal in one line."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from track_core.rfid.log import (
    EXAMPLE_CHANNELS,
    SIM_EPC,
    LogError,
    LogMeta,
    read_log,
    simulate_walk,
    write_example,
    write_log,
)
from track_core.rfid.protocol import CommandKind
from track_core.rfid.signal import PhaseProcessor, UnwrapConfig

REPO = Path(__file__).resolve().parents[4]
EXAMPLE = REPO / 'data/rfid/example-walk.csv'
HEAD = 'time,epc,antenna,channel,carrier_mhz,phase,rssi,event,value'
EPC = 'E2001234ABCD'


def _write(tmp_path: Path, *rows: str, head: str = HEAD, name: str = 'log.csv', bom: bool = False) -> Path:
    p = tmp_path / name
    p.write_text(('\ufeff' if bom else '') + '\n'.join([head, *rows]) + '\n', encoding='utf-8')
    return p


def _reads(t0: float, n: int, epc: str = EPC) -> list[str]:
    return [f'{t0 + 0.003 * j:.6f},{epc},1,1,920.625,{1.0 + 0.01 * j:.4f},-50.0,,' for j in range(n)]


GOOD = ['0.0,,,,,,,move_start,0.5', *_reads(0.001, 30), '0.2,,,,,,,move_end,', '0.2,,,,,,,turn,-30',
        *_reads(0.21, 5)]


def test_round_trip_of_a_simulated_walk(tmp_path):
    acts = simulate_walk(3)
    meta = LogMeta(carrier_mhz=920.625)
    log = read_log(write_log(tmp_path / 'w.csv', acts, meta, SIM_EPC, EXAMPLE_CHANNELS))
    assert log.epc == SIM_EPC and log.has_truth and log.carrier_hz == pytest.approx(920.625e6)
    assert [a.kind for a in log.actions] == [a.kind for a in acts]
    assert log.n_reads == sum(len(a.stream) for a in acts)
    for got, want in zip(log.actions, acts, strict=True):
        assert got.value == pytest.approx(want.value, abs=1e-4)
        np.testing.assert_allclose(got.stream.phase, want.stream.phase, atol=1e-6)
        np.testing.assert_allclose(got.stream.t, want.stream.t, atol=1e-6)
        np.testing.assert_allclose(got.stream.carrier_hz, want.stream.carrier_hz, atol=1e3)
        np.testing.assert_allclose(got.stream.xy, want.stream.xy, atol=1e-4)
        np.testing.assert_allclose(got.pose, want.pose, atol=1e-4)


def test_shipped_example_is_what_write_example_writes(tmp_path):
    assert EXAMPLE.stat().st_size < 100_000
    assert write_example(tmp_path / 'x.csv').read_bytes() == EXAMPLE.read_bytes()


def test_example_moves_process_to_the_true_dphi():
    log = read_log(EXAMPLE)
    ph = log.phase_model()
    proc = PhaseProcessor(UnwrapConfig.real_reader(ph))
    err = [proc.process(a.stream).dphi - a.truth_dphi(ph.k) for a in log.moves]
    assert len(err) == 8 and all(math.isfinite(e) for e in err)
    assert np.median(np.abs(err)) < 0.05            # rad; a wrong sign would be off by ~2|dφ| (> 1 rad here)


def test_bom_and_metadata_and_channel_table(tmp_path):
    rows = [r.replace(',1,920.625,', ',2,,') for r in GOOD]
    p = _write(tmp_path, *rows, head=f'# channels_mhz: 920.625 921.125\n# a free comment\n{HEAD}', bom=True)
    log = read_log(p)
    assert log.epc == EPC and [a.kind for a in log.actions] == [CommandKind.MOVE, CommandKind.TURN]
    assert np.all(log.actions[0].stream.carrier_hz == 921.125e6)
    assert log.actions[0].value == 0.5 and log.actions[1].value == pytest.approx(math.radians(-30))
    assert len(log.actions[0].stream) == 30 and len(log.actions[1].stream) == 5
    assert (log.actions[0].stream.t_start, log.actions[0].stream.t_end) == (0.0, 0.2)


def test_reads_of_other_tags_are_dropped_and_counted(tmp_path):
    p = _write(tmp_path, *GOOD, *_reads(0.3, 4, 'AAAA'))
    with pytest.raises(LogError, match=r'reads of 2 tags .* choose one with epc'):
        read_log(p)
    log = read_log(p, epc=EPC.lower())
    assert log.other_reads == 4 and log.n_reads == 35
    with pytest.raises(LogError, match='no read of the tag BBBB'):
        read_log(p, epc='BBBB')


@pytest.mark.parametrize(('rows', 'head', 'match'), [
    ([GOOD[0], GOOD[1].replace(',1.0000,', ',nan,')], HEAD, r'line 3, column phase: .nan. is not a finite'),
    ([GOOD[0], GOOD[1].replace(',1.0000,', ',7.0,')], HEAD, r'line 3, column phase: 7 is outside \[0, 6.28'),
    ([GOOD[0], GOOD[1].replace(EPC, 'E20X')], HEAD, r'line 3, column epc: .E20X. is not an EPC'),
    ([GOOD[0], GOOD[1].replace(EPC, 'E20')], HEAD, r'line 3, column epc'),
    ([GOOD[0], GOOD[2], GOOD[1]], HEAD, r'line 4, column time: 0.001 s is before .* \(line 3\)'),
    ([GOOD[0], GOOD[1].replace(',-50.0,', ',,')], HEAD, r'line 3, column rssi: .. is not a number'),
    ([GOOD[0], GOOD[1].replace(',1,1,', ',0,1,')], HEAD, r'line 3, column antenna'),
    (GOOD[1:], HEAD.replace(',rssi', ''), r'line 1: missing column rssi'),
    (GOOD[1:], HEAD.replace(',channel,carrier_mhz', ''), r'missing column channel or carrier_mhz'),
    ([GOOD[0], GOOD[1] + ',extra'], HEAD, r'line 3: 10 fields, the header \(line 1\) has 9'),
    ([GOOD[0], '0.1,,,,,,,jump,'], HEAD, r"line 3, column event: 'jump' is not one of"),
    ([GOOD[0], '0.1,,,,,,,move_start,0.5'], HEAD, r'line 3, column event: move_start inside the MOVE .* line 2'),
    (['0.1,,,,,,,move_end,'], HEAD, r'line 2, column event: move_end without a move_start'),
    (GOOD[:5], HEAD, r'line 2: the MOVE started here has no move_end'),
    (['0.1,,,,,,,turn,nan'], HEAD, r'line 2, column value: .nan. is not a finite'),
    (GOOD, f'# wrap: 3pi\n{HEAD}', r"line 1: wrap '3pi' is not one of pi, 2pi"),
    (GOOD, f'# sign: llrp\n{HEAD}', r"line 1: unknown metadata key 'sign'"),
    ([r.replace(',1,920.625,', ',3,,') for r in GOOD], HEAD, r'line 3, column channel: channel 3 is not in the hop'),
])
def test_bad_rows_are_refused_in_one_line_naming_line_and_column(tmp_path, rows, head, match):
    p = _write(tmp_path, *rows, head=head)
    with pytest.raises(LogError, match=match) as exc:
        read_log(p)
    assert '\n' not in str(exc.value) and str(exc.value).startswith('log.csv: ')


def test_a_file_that_is_not_utf8_is_refused(tmp_path):
    p = tmp_path / 'log.csv'
    p.write_bytes(HEAD.encode() + b'\n\xff\xfe\n')
    with pytest.raises(LogError, match='not UTF-8'):
        read_log(p)
