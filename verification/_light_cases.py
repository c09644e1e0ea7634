"""Case functions for the cluster tests, in a module that imports nothing heavy: a worker
that unpickles one imports only this (a worker restarted after a crash starts quickly).
"""

from __future__ import annotations

import os

__all__ = ["square_or_fail", "threads"]


def threads(dask_worker=None) -> dict:
    """The compute threads a worker runs with: numba's, and the BLAS variables."""
    import numba

    return {
        "numba": numba.config.NUMBA_NUM_THREADS,
        **{k: os.environ.get(k) for k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS")},
    }


def square_or_fail(x):
    """x * x; raises for 3, and for 5 kills its worker process (a crash)."""
    if x == 3:
        raise ValueError("three is not allowed")
    if x == 5:
        os._exit(7)
    return x * x
