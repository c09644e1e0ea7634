"""`solve_impacts` on every core, bit for bit the one-thread result (issue 27, goal 4).

The power-law batch kernels run one zeta (sums) or one impact (fields) per thread
step, so the thread count must not change a single bit. Speed: benchmarks/bench_exact.py.
"""

from __future__ import annotations

import numba
import numpy as np
import pytest

from reference_impl import PowerLaw, solve_impacts
from reference_impl.exact import batch
from verification.assertions import assert_true

N_IMPACTS = 3000  # a few ms per call; enough rows for every thread to take some


def _workload():
    rng = np.random.default_rng(2027)
    v = 10.0 ** rng.uniform(-1.0, 1.0, N_IMPACTS)
    z = rng.uniform(0.0, 0.95, N_IMPACTS)  # past 0.9: the second pass and solve_impact too
    z[: N_IMPACTS // 2] = np.repeat(np.linspace(0.0, 0.89, 30), N_IMPACTS // 60)  # a grid
    return v, z


def test_batch_kernels_are_parallel():
    for kernel in (
        batch._gj_batch,
        batch._power_law_fill,
        batch._count_invalid,
    ):
        assert_true(
            kernel.targetoptions.get("parallel") is True,
            got=f"{kernel.py_func.__name__} compiled with {kernel.targetoptions}",
            should="parallel=True (numba prange over zetas / impacts)",
            claim="solve_impacts",
            call=kernel.py_func.__name__,
        )


def test_solve_impacts_same_bits_on_one_thread_and_all():
    cores = numba.config.NUMBA_NUM_THREADS
    if cores < 2:
        pytest.skip("one numba thread on this machine: nothing to compare")
    pot, m = PowerLaw(1.0e9, 1.5), 0.0041
    v, z = _workload()
    before = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = solve_impacts(pot, m, v, z)
        numba.set_num_threads(cores)
        every = solve_impacts(pot, m, v, z)
    finally:
        numba.set_num_threads(before)
    for key in one:
        same = np.array_equal(one[key], every[key])
        assert_true(
            same,
            got=f"{key} differs at {np.flatnonzero(one[key] != every[key])[:3]}",
            should=f"identical on 1 and {cores} threads",
            claim="solve_impacts",
            call="solve_impacts(hertz, 0.0041, 3000 speeds, zetas)",
        )


def test_unique_zetas_is_numpy_unique():
    v, z = _workload()
    tiny = float(np.finfo(float).tiny)
    for zs in (z, np.sort(z), z[:1], z[:0], np.full(7, 0.3), np.array([0.2, -0.0, 0.0, 0.2])):
        starts = np.empty(zs.size, dtype=np.bool_)
        batch._count_invalid(np.resize(v, zs.size), zs, 0.0041, tiny, starts)
        zu = batch._unique_zetas(zs, starts)
        want = np.unique(zs)
        assert_true(
            np.array_equal(zu, want),
            got=f"{zu[:5]}",
            should=f"{want[:5]} (numpy.unique)",
            claim="solve_impacts",
            call=f"_unique_zetas({zs.size} zetas)",
        )
