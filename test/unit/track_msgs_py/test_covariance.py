"""The planar 6×6 covariance: the x/y block, z/roll/pitch 0, yaw not estimated, and how a reader tells them apart."""

import numpy as np
import pytest

from track_msgs_py.covariance import (
    NOT_ESTIMATED_VARIANCE,
    PLANAR_VARIANCE,
    as_shape,
    not_estimated,
    planar_covariance,
    xy_block,
)

C = np.array([[4.0, 0.3], [0.3, 2.5]])


@pytest.mark.parametrize(('yaw', 'expected_yaw'), [((), NOT_ESTIMATED_VARIANCE), ((0.02,), 0.02)])
def test_planar_covariance_layout(yaw, expected_yaw):
    cov = planar_covariance(C, *yaw)
    assert cov.shape == (36,) and cov.dtype == np.float64
    np.testing.assert_array_equal(cov[[0, 1, 6, 7]], C.reshape(4))  # the x/y block is entries 0, 1, 6, 7
    full = cov.reshape(6, 6)
    np.testing.assert_array_equal(np.diag(full)[2:], [PLANAR_VARIANCE] * 3 + [expected_yaw])
    off = full - np.diag(np.diag(full))
    off[:2, :2] = 0.0
    assert PLANAR_VARIANCE == 0.0 and not off.any()
    assert ((full >= 0.0) & (full <= 1e14)).all()  # within the input policy's bounds


def test_xy_block_is_a_float64_copy():
    cov = planar_covariance(C)
    block = xy_block(list(cov))
    np.testing.assert_array_equal(block, C)
    block[0, 0] = -1.0
    assert cov[0] == 4.0 and xy_block(cov).dtype == np.float64


def test_not_estimated_is_the_threshold_of_the_convention():
    assert not_estimated(NOT_ESTIMATED_VARIANCE) and not_estimated(1e12)
    assert not not_estimated(0.999e6) and not not_estimated(PLANAR_VARIANCE)
    assert not_estimated(np.diag(planar_covariance(C).reshape(6, 6))).tolist() == [False] * 5 + [True]


def test_as_shape_names_a_wrong_shape():
    np.testing.assert_array_equal(as_shape([1, 2], (2,), 'z'), [1.0, 2.0])
    with pytest.raises(ValueError, match=r'R must have shape \(2, 2\), got \(3,\)'):
        as_shape([1.0, 2.0, 3.0], (2, 2), 'R')
