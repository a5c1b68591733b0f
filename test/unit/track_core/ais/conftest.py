"""Shared fixtures: the real Solent file (skipped when the shared data are absent) and tiny synthetic files."""

from __future__ import annotations

import numpy as np
import pytest

from track_core.ais import AisData, default_path, read_ais

HEADER = 'Time,MMSI,Latitude_degrees,Longitude_degrees,COG_degrees,SOG_knots\n'


@pytest.fixture(scope='session')
def solent() -> AisData:
    if not default_path().is_file():
        pytest.skip(f'shared AIS data not found: {default_path()}')
    return read_ais()


@pytest.fixture
def write_csv(tmp_path):
    """write_csv(rows) → path of a CSV with the Solent header and the given data lines."""

    def _write(rows: list[str], header: str = HEADER):
        p = tmp_path / 'ais.csv'
        p.write_text(header + ''.join(r + '\n' for r in rows))
        return p

    return _write


def _synthetic(ships: dict[int, list[tuple[float, float, float]]], t0: float = 1.45e9) -> AisData:
    rows = sorted((t, m, la, lo) for m, reps in ships.items() for t, la, lo in reps)
    t, m, la, lo = (np.array(c) for c in zip(*rows, strict=True))
    nan = np.full(t.size, np.nan)
    return AisData(t - t[0], m.astype(np.int64), la.astype(float), lo.astype(float), nan, nan, t0, t.size, {})


@pytest.fixture
def synthetic():
    """synthetic({mmsi: [(t, lat, lon), ...]}) → AisData (no validation: for the truth/source tests)."""
    return _synthetic
