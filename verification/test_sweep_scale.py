"""Sweeps that scale (issue 27, goal 5): one compute thread per local worker, cases
grouped per Dask task, and a group whose worker dies rerun case by case.
"""

from __future__ import annotations

from reference_impl.sweep._runner import _MAX_CHUNK, _chunk_size, iter_outcomes, open_client
from verification._light_cases import square_or_fail, threads
from verification._sweeps import needs_dask
from verification.assertions import assert_true

CLAIM = "sweep"  # the sweep machinery, not a paper claim


def test_cases_per_task():
    """About 8 tasks per worker thread, 1 to _MAX_CHUNK cases each."""
    got = [_chunk_size(n, t) for n, t in ((6, 2), (64, 2), (480, 2), (10**5, 32), (0, 1))]
    assert_true(
        got == [1, 4, _MAX_CHUNK, _MAX_CHUNK, 1],
        got=str(got),
        should=f"[1, 4, {_MAX_CHUNK}, {_MAX_CHUNK}, 1]",
        claim=CLAIM,
        call="_chunk_size",
    )


@needs_dask
def test_grouped_cases_one_thread_each_and_a_dead_worker_fails_one_case():
    import os

    import dask

    before = os.environ.get("NUMBA_NUM_THREADS")
    # One death is enough to give up on a task (the default retries it on 3 workers).
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}):
        with open_client(workers=2) as client:
            per_worker = list(client.run(threads).values())
            outs = sorted(
                iter_outcomes(client, square_or_fail, list(range(12)), chunk=4),
                key=lambda o: o.index,
            )
    assert_true(
        per_worker == [{"numba": 1, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}] * 2,
        got=str(per_worker),
        should="one numba and one BLAS thread in each of the 2 workers",
        claim=CLAIM,
        call="open_client(workers=2).run",
    )
    # The workers' one numba thread must not reach this process: numba re-reads its config
    # on every compilation, and this process's parallel kernels, once launched with 1
    # thread, then fail to compile anything (distributed writes its pre-spawn environment
    # into the client's os.environ).
    assert_true(
        os.environ.get("NUMBA_NUM_THREADS") == before,
        got=repr(os.environ.get("NUMBA_NUM_THREADS")),
        should=f"{before!r}, as before the cluster started",
        claim=CLAIM,
        call="open_client(workers=2)",
    )
    values = [o.value for o in outs]
    want = [x * x if x not in (3, 5) else None for x in range(12)]
    assert_true(
        values == want and "three is not allowed" in outs[3].error
        and "worker died" in outs[5].error,
        got=f"{values}; errors {outs[3].error!r}, {outs[5].error!r}",
        should=f"{want}: the crash fails case 5 only, not the 3 others of its group",
        claim=CLAIM,
        call="iter_outcomes(chunk=4)",
    )  # fmt: skip
