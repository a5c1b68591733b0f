import numpy as np

from track_core.slam.blas import _openblas_libs, single_threaded_blas


def test_single_threaded_blas_restores_thread_counts():
    np.ones((4, 4)) @ np.ones((4, 4))
    libs = _openblas_libs()
    before = [int(get()) for _, get in libs]
    with single_threaded_blas() as n:
        assert n == len(libs)
        assert all(int(get()) == 1 for _, get in libs)
        np.testing.assert_allclose(np.ones((50, 50)) @ np.ones((50, 50)), 50.0)
    assert [int(get()) for _, get in libs] == before
