"""track-bag-recover on damaged files: a corrupt chunk is skipped and the others recovered; a file with no
complete message is one line, exit 1, no bag written; an output that cannot be written is one line, exit 2."""

from __future__ import annotations

import pytest
from rosbags.rosbag2 import Reader

from track_nodes.bag.recover import EXIT_NOTHING, main
from track_nodes.bag.typestore import typestore
from track_nodes.bag.writer import CHUNK_BYTES, BagWriter

N = 3 * CHUNK_BYTES // 5000  # about three chunks


@pytest.fixture
def killed(tmp_path):
    """The .mcap of a recorder killed after three chunks were flushed (no summary, no metadata.yaml)."""
    w = BagWriter(tmp_path / 'killed').open()
    conn = w.add_connection('/raw', 'std_msgs/msg/String', typestore=typestore())
    for i in range(N):
        w.write(conn, 10**18 + i, i.to_bytes(4, 'little') + bytes(5000))
    w.flush()
    w.abort()
    return tmp_path / 'killed'


def _run(capsys, *args) -> tuple[int, list[str], list[str]]:
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out.splitlines(), err.splitlines()


def test_a_corrupt_chunk_is_skipped_and_the_others_recovered(killed, capsys, flip_bit):
    flip_bit(killed / 'killed.mcap', 2)
    code, out, err = _run(capsys, killed)
    assert code == 0 and err == []
    assert '1 corrupt chunk(s) skipped (CRC mismatch)' in out[0]
    with Reader(killed.with_name('killed-recovered')) as reader:
        got = [int.from_bytes(raw[:4], 'little') for _, _, raw in reader.messages()]
    assert 0 < len(got) < N and got == sorted(got) and got[0] == 0 and got[-1] == N - 1  # a run from the middle gone


def _every_chunk_flipped(mcap, flip_bit):
    for k in (1, 2, 3, 4):
        try:
            flip_bit(mcap, k)
        except ValueError:
            break


@pytest.mark.parametrize('how', ['header-only', 'noise', 'cut-in-first-chunk-head', 'every-chunk-flipped'])
def test_nothing_to_recover_is_one_line_and_exit_1(killed, capsys, flip_bit, how):
    mcap = killed / 'killed.mcap'
    data = mcap.read_bytes()
    first_chunk = data.index(b'\x06', 8 + 9 + int.from_bytes(data[9:17], 'little'))  # after the header record
    if how == 'header-only':
        mcap.write_bytes(data[:first_chunk])
    elif how == 'noise':
        mcap.write_bytes(data[:8] + bytes((i * 151 + 7) % 256 for i in range(3000)))
    elif how == 'cut-in-first-chunk-head':
        mcap.write_bytes(data[:first_chunk + 30])
    else:
        _every_chunk_flipped(mcap, flip_bit)
    code, out, err = _run(capsys, killed)
    assert code == EXIT_NOTHING and out == [] and len(err) == 1, err
    assert 'nothing to recover' in err[0] and str(mcap) in err[0]
    assert not killed.with_name('killed-recovered').exists()


@pytest.mark.parametrize('where', ['under-a-file', 'proc'])
def test_an_output_that_cannot_be_written_is_one_line_and_exit_2(killed, capsys, tmp_path, where):
    if where == 'under-a-file':
        (tmp_path / 'file').write_text('x')
        out = tmp_path / 'file' / 'recovered'
    else:
        out = '/proc/recovered-bag'
    code, stdout, err = _run(capsys, killed, out)
    assert code == 2 and stdout == [] and len(err) == 1 and str(out) in err[0] and 'cannot write' in err[0], err
