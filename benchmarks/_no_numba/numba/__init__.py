"""A stand-in for numba, for measurement only (``benchmarks/bench_startup.py``).

Put first on ``PYTHONPATH``, it makes ``import numba`` cheap and every ``@numba.njit``
function plain Python (its ``py_func`` itself), so that the package runs its kernels
interpreted without importing numba at all: what a path free of numba would cost and
give. It is no path for users: the interpreted kernels are not bit for bit the compiled
ones everywhere (the benchmark records where they differ), and they are slow on large
inputs. It covers what the exact solver's modules use: ``njit``, ``prange``,
``get_num_threads``, ``parallel_chunksize`` and ``extending.overload``.
"""

from __future__ import annotations

import contextlib

__all__ = ["get_num_threads", "jit", "njit", "parallel_chunksize", "prange"]
__version__ = "0+stand-in"


def _plain(func):
    func.py_func = func  # what python_solver and _jit read from a dispatcher
    return func


def njit(*args, **options):
    """``@njit`` or ``@njit(...)``: the function itself, run by the interpreter."""
    if len(args) == 1 and callable(args[0]) and not options:
        return _plain(args[0])
    return _plain


jit = njit
prange = range


def get_num_threads() -> int:
    """One thread: the interpreter runs every loop serially."""
    return 1


@contextlib.contextmanager
def parallel_chunksize(size):
    """No parallel loops here; the chunk size is ignored."""
    yield
