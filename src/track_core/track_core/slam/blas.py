"""Limit OpenBLAS threads while the SLAM filter runs (``single_threaded_blas``).

Why: every matrix product of the CEKF scan update is small (n_A ≈ 300 × 2k ≈ 12), yet large
enough for OpenBLAS to split it across threads. On a machine whose cores are busy with other
processes the worker threads spin-wait for each other, and a small solve becomes two orders of
magnitude slower. With one BLAS thread the whole run is compute-bound and predictable; on an
idle machine the difference is small.

How: the process-wide thread count of every OpenBLAS library already loaded (numpy's and
scipy's wheels each bundle one; their ``set_num_threads`` symbols carry ``scipy_`` prefixes
and a ``64_`` suffix for the ILP64 build) is set through ``ctypes`` and restored on exit, the
mechanism ``threadpoolctl`` uses, which this project does not depend on. Where no OpenBLAS is
found (another BLAS, another OS) the context manager does nothing. It changes process-global
state, so a ROS node should enter it once around its executor rather than per callback.
"""

from __future__ import annotations

import ctypes
import logging
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

log = logging.getLogger(__name__)

_SET = ('openblas_set_num_threads', 'openblas_set_num_threads64_', 'scipy_openblas_set_num_threads',
        'scipy_openblas_set_num_threads64_')
_GET = ('openblas_get_num_threads', 'openblas_get_num_threads64_', 'scipy_openblas_get_num_threads',
        'scipy_openblas_get_num_threads64_')


def _openblas_libs() -> list[tuple[object, object]]:
    """(set, get) function pairs of the OpenBLAS libraries mapped into this process."""
    try:
        maps = Path('/proc/self/maps').read_text().splitlines()
    except OSError:
        return []
    paths = sorted({ln.split()[-1] for ln in maps if 'openblas' in Path(ln.split()[-1]).name.lower()})
    out = []
    for p in paths:
        try:
            lib = ctypes.CDLL(p)
        except OSError:
            continue
        fset = next((getattr(lib, n) for n in _SET if hasattr(lib, n)), None)
        fget = next((getattr(lib, n) for n in _GET if hasattr(lib, n)), None)
        if fset is not None and fget is not None:
            fget.restype = ctypes.c_int
            out.append((fset, fget))
    return out


@contextmanager
def single_threaded_blas(n_threads: int = 1) -> Iterator[int]:
    """Run the body with ``n_threads`` OpenBLAS threads; yields the number of libraries limited."""
    libs = _openblas_libs()
    saved = []
    for fset, fget in libs:
        saved.append(int(fget()))
        fset(ctypes.c_int(n_threads))
    try:
        yield len(libs)
    finally:
        for (fset, _), n in zip(libs, saved, strict=True):
            fset(ctypes.c_int(n))
