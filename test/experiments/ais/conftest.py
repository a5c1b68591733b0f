"""The real Solent file (skipped when the shared data are absent)."""

from __future__ import annotations

import pytest

from track_core.ais import AisData, default_path, read_ais


@pytest.fixture(scope='session')
def solent() -> AisData:
    if not default_path().is_file():
        pytest.skip(f'shared AIS data not found: {default_path()}')
    return read_ais()
