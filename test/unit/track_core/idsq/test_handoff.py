import dataclasses

import numpy as np
import pytest

from track_core.idsq.grid import GridSpec, uniform_belief
from track_core.idsq.handoff import (
    HEADER_BYTES,
    Handoff,
    decode_handoff,
    encode_handoff,
    payload_bytes,
    peek_header,
    receive_handoff,
    validate_handoff,
)

GRID = GridSpec.for_field()


def _handoff(**kw) -> Handoff:
    b = uniform_belief(GRID)
    h = Handoff.from_belief(7, 3, 5, type(b)(GRID, b.idx[:100], np.full(100, 0.01)))
    return dataclasses.replace(h, **kw)


def test_roundtrip_and_size():
    h = _handoff()
    data = encode_handoff(h)
    assert len(data) == payload_bytes(100) == HEADER_BYTES + 800
    g, why = receive_handoff(data, GRID, n_sensors=10, receiver=5)
    assert why is None
    assert (g.step, g.sender, g.receiver, g.grid) == (7, 3, 5, GRID)
    np.testing.assert_array_equal(g.idx, h.idx)
    np.testing.assert_allclose(g.belief().mass, h.mass, rtol=1e-6)
    assert np.isclose(g.belief().mass.sum(), 1.0)


@pytest.mark.parametrize(('change', 'reason'), [
    ({'mass': np.r_[np.nan, np.full(99, 0.01)]}, 'non-finite'),
    ({'mass': np.r_[-0.01, 0.02, np.full(98, 0.01)]}, 'negative mass'),
    ({'grid': GridSpec(0.0, 0.0, 10.0, 15, 25)}, 'wrong grid'),
    ({'mass': np.full(100, 0.02)}, 'sums to'),
    ({'idx': np.r_[np.arange(99), 98]}, 'strictly increasing'),
    ({'idx': np.arange(1450, 1550)}, 'outside'),
    ({'receiver': 6}, 'addressed'),
])
def test_malformed_handoff_is_refused_with_one_line_reason(change, reason):
    h = _handoff(**change)
    why = validate_handoff(h, GRID, n_sensors=10, receiver=5)
    assert why is not None and reason in why and '\n' not in why
    g, why2 = receive_handoff(encode_handoff(h, check=False), GRID, n_sensors=10, receiver=5)
    assert g is None and reason in why2
    if reason not in ('wrong grid', 'addressed'):  # the sender cannot know the receiver's grid/id check
        with pytest.raises(ValueError, match='refusing'):
            encode_handoff(h)


def test_undecodable_bytes_are_refused():
    data = encode_handoff(_handoff())
    for bad, reason in [(data[:20], 'shorter'), (data[:-4], 'length'), (b'XXXX' + data[4:], 'magic')]:
        g, why = receive_handoff(bad, GRID)
        assert g is None and reason in why and '\n' not in why
    with pytest.raises(ValueError, match='shorter'):
        decode_handoff(b'')


def test_peek_header_reads_the_address_of_unusable_bytes():
    data = encode_handoff(_handoff())
    assert peek_header(data) == (3, 5, 7)
    assert peek_header(data[:14]) == (3, 5, 7)  # header cut after the step: still answerable
    for bad in (data[:13], b'', b'XXXX' + data[4:], data[:4] + b'\x09' + data[5:], b'IDSQ' + bytes(20)):
        assert peek_header(bad) is None
    h, why = receive_handoff(data[:30], GRID)  # refused, yet the sender can be told
    assert h is None and 'shorter' in why and peek_header(data[:30]) == (3, 5, 7)


# --- the field-level package (what track_msgs/IdsqHandoff carries) --------------------------------

def _same_handoff(a: Handoff, b: Handoff) -> None:
    assert (a.step, a.sender, a.receiver, a.grid) == (b.step, b.sender, b.receiver, b.grid)
    np.testing.assert_array_equal(a.idx, b.idx)
    np.testing.assert_array_equal(a.mass, b.mass)  # bit for bit: both came through float32
    assert (a.motion is None) == (b.motion is None)


def test_the_package_reads_back_what_the_bytes_read_back():
    from track_core.idsq.handoff import from_package, to_package

    h = _handoff(mass=np.random.default_rng(2).dirichlet(np.ones(100)))
    p = to_package(h)
    assert p.version == 1 and p.cells.dtype == np.dtype('<u4') and p.mass.dtype == np.dtype('<f4')
    _same_handoff(from_package(p), decode_handoff(encode_handoff(h)))


@pytest.mark.parametrize(('change', 'reason'), [
    ({'version': 4}, 'unknown handoff version 4'),
    ({'version': 0}, 'unknown handoff version 0'),
    ({'mass': np.full(99, 0.01, dtype='<f4')}, '100 cells but 99 masses'),
    ({'velocity': (1.0, 0.0)}, 'velocity/observations are set in a version-1'),
    ({'hypotheses': 9}, 'bank_spacing/hypotheses are set in a version-1'),
    ({'cell': float('nan')}, 'bad grid'),
    ({'nx': 0}, 'bad grid'),
    ({'version': 2, 'velocity': (float('nan'), 0.0)}, 'bad motion'),
    ({'version': 3, 'bank_spacing': float('inf'), 'hypotheses': 9}, 'bad joint belief'),
])
def test_an_unreadable_package_is_one_line(change, reason):
    from track_core.idsq.handoff import from_package, to_package

    p = dataclasses.replace(to_package(_handoff()), **change)
    with pytest.raises(ValueError) as exc:
        from_package(p)
    assert reason in str(exc.value) and '\n' not in str(exc.value)


def test_read_package_sorts_bytes_into_what_the_ledger_takes():
    from track_core.idsq.handoff import Revocation, Unusable, encode_revoke, read_package

    data = encode_handoff(_handoff())
    assert isinstance(read_package(data), Handoff)
    assert read_package(encode_revoke(7, 2, 5)) == Revocation(2, 5, 7)
    bad = read_package(data[:30])
    assert isinstance(bad, Unusable) and 'shorter' in bad.reason and bad.address == (3, 5, 7)
    assert read_package(b'x') == Unusable('handoff of 1 bytes is shorter than the 46-byte header', None)
