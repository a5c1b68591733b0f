import math

import numpy as np
import pytest

from track_core.rfid.phase import SPEED_OF_LIGHT, PhaseModel


def test_wavelength_and_slope_from_the_carrier():
    pm = PhaseModel(carrier_hz=866.3e6)
    assert pm.wavelength == pytest.approx(SPEED_OF_LIGHT / 866.3e6)
    assert pm.wavelength == pytest.approx(0.346, abs=1e-3)
    assert pm.k == pytest.approx(4 * math.pi / pm.wavelength)
    assert PhaseModel(carrier_hz=915e6).wavelength < pm.wavelength


@pytest.mark.parametrize('period', [math.pi, 2 * math.pi])
def test_wrap_is_half_open_zero_excluded(period):
    pm = PhaseModel(wrap_period=period)
    phi = np.array([0.0, period, -period, 1e-9, period + 1e-9, -1e-9, 123.456, -123.456])
    w = pm.wrap(phi)
    assert np.all(w > 0) and np.all(w <= period)
    np.testing.assert_allclose(np.mod(w - phi, period) % period, 0.0, atol=1e-9)
    assert pm.wrap(0.0) == pytest.approx(period)


def test_dphi_eq6_sign_and_value():
    pm = PhaseModel()
    s, e = np.array([3.0, 4.0]), np.array([3.0 * 0.9, 4.0 * 0.9])   # 0.5 m toward the tag
    assert pm.dphi(s, e) == pytest.approx(-pm.k * 0.5)
    assert pm.dphi(e, s) == pytest.approx(pm.k * 0.5)
    # eq. 6 is minus the change of eq. 3's phase
    assert pm.dphi(s, e) == pytest.approx(-(pm.phase(4.5) - pm.phase(5.0)))


def test_eq11_noise_std():
    pm = PhaseModel(s_theta=math.radians(5.5))
    assert pm.dphi_noise_std(0.1) == pytest.approx(math.sqrt(0.5 * (pm.k * 0.1) ** 2 + math.radians(5.5) ** 2))
    assert pm.dphi_noise_std(0.0) == pytest.approx(math.radians(5.5))


@pytest.mark.parametrize('kw', [{'carrier_hz': 2.4e9}, {'carrier_hz': 800e6}, {'wrap_period': 1.0},
                                {'s_theta': -0.1}, {'s_theta': float('nan')}])
def test_bad_parameters_are_rejected(kw):
    with pytest.raises(ValueError):
        PhaseModel(**kw)


def test_with_wrap_names():
    assert PhaseModel.with_wrap('pi').wrap_period == pytest.approx(math.pi)
    assert PhaseModel.with_wrap('2pi').wrap_period == pytest.approx(2 * math.pi)
    with pytest.raises(ValueError, match='wrap'):
        PhaseModel.with_wrap('tau')
