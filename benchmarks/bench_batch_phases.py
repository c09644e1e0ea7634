"""Serial share of the `solve_impacts` batch rows of `bench_exact`, on one thread (issue 27, goal 4).

A two-thread speed-up measured on a shared machine says more about the neighbours than
about the code. The serial share does not need a free core: on one numba thread, the
CPU time of the parallel (prange) kernels against the whole call, call by call, on the
three workloads of `bench_exact` (the 1e5 distinct-zeta impacts, the 50 x 2000 grid, the
general-law batch of 2000 speeds), each called ``--calls`` times in a row. With s the median of (call - kernels) / call,
Amdahl's bound on c cores is 1 / (s + (1 - s) / c). What separates a measured speed-up
from that bound is the kernels' own parallel efficiency, which only a quiet machine
measures (`bench_exact`'s batch rows). On a busy machine the serial Python runs with
caches its neighbours emptied, so s comes out higher than on a quiet one.

``--fill-chunks`` also times the grid on every core with the fill in numba's equal shares
(the default) and in chunks handed out as threads free up: on a quiet machine only.

Run: ``python -m benchmarks.bench_batch_phases [--calls N] [--fill-chunks] [--json FILE]``
(~1 minute).
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

import numba

from reference_impl.exact import _law_batch, batch

from ._machine import machine_info
from ._record import write_json
from .bench_exact import batch_workloads

# Impacts per chunk of the grid's fill, against numba's equal shares (`--fill-chunks`).
FILL_CHUNK_TRIED = 2048
# The prange kernels each workload calls (module, global name): the rest of a call is serial.
_PARALLEL = (
    (batch, "_count_invalid"),
    (batch, "_gj_batch"),
    (batch, "_power_law_fill"),
    (_law_batch, "_solve_rows"),
)


def _workloads():
    """(label, call) of each batch row of `bench_exact`, the same inputs."""
    return tuple((label, call) for label, _, call, _ in batch_workloads())


def run(calls: int) -> dict:
    """Per workload: median CPU time of a call and of each kernel, s, Amdahl's bound."""
    spent: dict[str, float] = {}
    originals = [(mod, name, getattr(mod, name)) for mod, name in _PARALLEL]

    def timed(name, fn):
        def call(*args):
            t0 = time.process_time()
            try:
                return fn(*args)
            finally:
                spent[name] = spent.get(name, 0.0) + time.process_time() - t0

        return call

    threads = numba.get_num_threads()
    load_before = os.getloadavg()[0]
    numba.set_num_threads(1)
    try:
        for mod, name, fn in originals:
            setattr(mod, name, timed(name, fn))
        samples: dict[str, list[dict]] = {}
        # One workload after another, as `bench_exact` times them (its arrays stay in the
        # caches from call to call; interleaving the workloads evicts them, and the grid's
        # serial share, its reads from memory, doubles).
        for label, call in _workloads():
            call()  # compile / warm
            samples[label] = []
            for _ in range(calls):
                spent.clear()
                t0 = time.process_time()
                call()
                total = time.process_time() - t0
                samples[label].append({"total": total, **spent})
    finally:
        for mod, name, fn in originals:
            setattr(mod, name, fn)
        numba.set_num_threads(threads)
    rows = []
    for label, rec in samples.items():
        kernels = sorted({k for r in rec for k in r} - {"total"})
        shares = [(r["total"] - sum(r.get(k, 0.0) for k in kernels)) / r["total"] for r in rec]
        s = statistics.median(shares)
        rows.append(
            {
                "workload": label,
                "call_ms_1_thread": statistics.median(r["total"] for r in rec) * 1e3,
                "kernel_ms": {
                    k: statistics.median(r.get(k, 0.0) for r in rec) * 1e3 for k in kernels
                },
                "serial_share": s,
                "amdahl_bound_2_cores": 1.0 / (s + (1.0 - s) / 2.0),
            }
        )
    return {
        "rows": rows,
        "calls": calls,
        "timing": "CPU time (process_time) on one numba thread, per call, median",
        "load_average_1min": load_before,
        "load_average_1min_after": os.getloadavg()[0],
        "machine": machine_info(),
    }


def fill_chunks(calls: int) -> dict:
    """The grid's wall time on one thread and on every core with the fill in numba's equal
    shares (chunk 0, the default `batch._FILL_CHUNK`) and handed out in chunks of
    `FILL_CHUNK_TRIED`, interleaved, median: whether the chunks pay on this machine (a
    quiet one: on a busy one a neighbour's time slice decides). Every variant's arrays
    compared bit for bit."""
    call = _workloads()[1][1]
    threads, chunk = numba.get_num_threads(), batch._FILL_CHUNK
    cores = numba.config.NUMBA_NUM_THREADS
    variants = ((1, 0), (cores, FILL_CHUNK_TRIED), (cores, 0))
    times: dict[tuple, list[float]] = {v: [] for v in variants}
    same = True
    load_before = os.getloadavg()[0]
    try:
        ref = None
        for th, ch in variants:
            numba.set_num_threads(th)
            batch._FILL_CHUNK = ch
            got = call()
            ref = ref or got
            same = same and all(got[k].tobytes() == ref[k].tobytes() for k in ref)
        for _ in range(calls):
            for th, ch in variants:
                numba.set_num_threads(th)
                batch._FILL_CHUNK = ch
                t0 = time.perf_counter()
                call()
                times[(th, ch)].append(time.perf_counter() - t0)
    finally:
        numba.set_num_threads(threads)
        batch._FILL_CHUNK = chunk
    t1 = statistics.median(times[variants[0]])
    return {
        "workload": _workloads()[1][0],
        "ms": {
            f"{th} threads, chunk {ch}": statistics.median(t) * 1e3 for (th, ch), t in times.items()
        },
        "speedup_chunked": t1 / statistics.median(times[variants[1]]),
        "speedup_equal_shares": t1 / statistics.median(times[variants[2]]),
        "bit_identical": same,
        "load_average_1min": load_before,
        "load_average_1min_after": os.getloadavg()[0],
    }


def _print(res: dict) -> None:
    print(f"solve_impacts serial share; {res['timing']}, {res['calls']} calls")
    for r in res["rows"]:
        ks = ", ".join(f"{k} {t:.3f}" for k, t in r["kernel_ms"].items())
        print(
            f"{r['workload']}: {r['call_ms_1_thread']:.3f} ms a call ({ks} ms in parallel"
            f" kernels); serial share s = {100 * r['serial_share']:.2f} %,"
            f" Amdahl bound on 2 cores {r['amdahl_bound_2_cores']:.3f}x"
        )
    fc = res.get("fill_chunks")
    if fc:
        ms = "; ".join(f"{k}: {t:.3f} ms" for k, t in fc["ms"].items())
        print(
            f"{fc['workload']}, wall: {ms}; speed-up {fc['speedup_chunked']:.3f}x chunked,"
            f" {fc['speedup_equal_shares']:.3f}x equal shares (identical: {fc['bit_identical']};"
            f" load {fc['load_average_1min']:.2f} -> {fc['load_average_1min_after']:.2f})"
        )
    mi = res["machine"]
    print(
        f"machine: {mi['platform']}, {mi['cpu_count']} cpus, load {res['load_average_1min']:.2f}"
        f" before, {res['load_average_1min_after']:.2f} after, commit {mi['commit']}"
    )


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--calls", type=int, default=30, help="calls per workload (median; >= 5)")
    ap.add_argument("--json", help="also write the result to this JSON file")
    ap.add_argument(
        "--fill-chunks",
        action="store_true",
        help="also time the grid on every core, fill in equal shares and chunked (wall)",
    )
    args = ap.parse_args(argv)
    if args.calls < 5:
        print(f"bench_batch_phases: error: --calls {args.calls}: at least 5", file=sys.stderr)
        return 2
    res = run(args.calls)
    if args.fill_chunks:
        res["fill_chunks"] = fill_chunks(max(args.calls, 50))
    _print(res)
    if args.json:
        write_json(args.json, res)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
