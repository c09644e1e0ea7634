"""The exact solvers against the strongest compiled peers, at equal error (issues 27 and 38).

Each row is one impact scored against its 30-digit mpmath truth. The peers
(`benchmarks._peers`, one column each): the compiled DOP853 on the plain equations
(`benchmarks.peer_dop853.solve_dop853`, the peer since issue 27), the same with q^1.5
written q sqrt(q) (`solve_dop853_sqrt`), DOP853 on the Sundman-regularised equations
(`benchmarks.peer_sundman`; power laws and their sums) and numbalsoda's dop853 on them
(`benchmarks.peer_numbalsoda`, where installed); each gives every output ours has (both
ends, q_max, U'(q_max) or the peak force). Each is run over a ladder of tolerances on
the row's set of `benchmarks._equal_error.IMPACTS` random impacts (speeds and damping
over the ranges used here; truth: ours, checked on a subset against mpmath), and takes
the cheapest rung whose WORST relative error over every output and impact is at most
max(ours, 1e-14) ("equal error"), or, when no rung gets there, its best rung (marked
``best``). The fastest peer at equal error is the ratio's denominator (``peer_*``);
every peer's time, rung and errors are under ``peers``. scipy's `solve_ivp` DOP853
(rtol 1e-12, Python per step) stays as a column only: no claim rests on it.

Rows: the universal law on every potential family (`solve_impact`, and the
`prepare(potential, m)` call when present), Hertz with each general damping law
(`solve_law_impact`), and `solve_impacts` with one thread and with every core on 1e5
Hertz impacts (distinct zetas; a 50 x 2000 grid) and on 2000 speeds of a general law.

Timing: CPU time (`time.process_time`) per call, the contestants of a row
interleaved block by block (each block ~10 ms per contestant), median of the
blocks; the batch rows use wall time, since their point is the use of several
cores. The JSON (format `SCHEMA`) records the load average before and after, and
the commit.

Goals (issue 27): universal law <= 8 us per impact from Python (prepared call) and
>= 20x the fastest peer at <= 1e-14; general laws >= 3x; `solve_impacts` with
every core >= 1.8x one thread on 2 cores.

Run: ``python -m benchmarks.bench_exact [--json FILE] [--blocks N] [--impacts N]
[--mp-subset N]``: the sets and their mpmath subsets take most of the time (~1 s per
30-digit impact: 10 rows x 50 of them); ``--blocks 1`` is a quick check of the timing.
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import sys
import time

import numpy as np

from reference_impl import PowerLaw, solve_impact, solve_impacts
from reference_impl.exact._general_law_mp import solve_law_impact_mp
from reference_impl.exact.general_law import prepare_law, solve_law_impact
from reference_impl.exact.solve import solve_impact_mp
from reference_impl.studies.laws import calibrated_laws, hertz
from reference_impl.studies.workprecision import FAMILY_ZETA, family_scenes

from . import peer_dop853 as peer
from ._equal_error import IMPACTS, MP_SUBSET, law_bound_ok, universal_bound_ok
from ._exact_print import numbalsoda_note, print_result
from ._machine import machine_info
from ._peer_columns import fastest, set_ok
from ._peer_columns import peer_columns as _peer_columns
from ._peers import PEERS
from ._record import write_json
from ._scipy_peer import scipy_dop853

# The record's format: 2 adds every peer's column (`peers`), the fastest peer at equal
# error as the ratio's denominator, and equal error over a random set (issue 38).
SCHEMA = "hcv-bench-exact/2"
TRUTH_DPS = 30
# The peer's tolerance ladder: rtol = 10^(-k/2), 1e-6 .. 1e-16 (atol scaled alike).
PEER_RTOLS = tuple(10.0 ** (-k / 2) for k in range(12, 33))
EQUAL_ERROR_FLOOR = 1e-14  # "equal error" is <= max(ours, this)
SCIPY_RTOL = 1e-12
BLOCK_S = 0.01  # CPU seconds per contestant and block
# Goals of issue 27.
GOAL_US = 8.0  # universal law, per impact from Python (prepared call)
GOAL_RATIO_UNIVERSAL = 20.0
GOAL_RATIO_LAW = 3.0
GOAL_PARALLEL = 1.8
# Batch workload: Hertz, random (v0, zeta) with every zeta distinct.
BATCH_N = 100_000
BATCH_ZETA_MAX = 0.85
GRID_ZETAS, GRID_SPEEDS = 50, 2000
# The general-law batch: Hunt-Crossley (the calibrated strength, e ~ 0.8 at 1 m/s).
LAW_BATCH = {"law": "hunt-crossley", "alpha": 0.37}
LAW_BATCH_N = 2000
LAW_V0 = 1.0


def _load() -> float | None:
    return os.getloadavg()[0] if hasattr(os, "getloadavg") else None


def _interleaved(contestants: dict, blocks: int) -> dict:
    """Median CPU seconds per call of each contestant, timed block by block in turn."""
    inner = {}
    for name, fn in contestants.items():
        fn()  # compile / warm caches
        t0 = time.process_time()
        fn()
        once = max(time.process_time() - t0, 1e-7)
        inner[name] = max(1, int(BLOCK_S / once))
    times = {name: [] for name in contestants}
    for _ in range(blocks):
        for name, fn in contestants.items():
            n = inner[name]
            t0 = time.process_time()
            for _ in range(n):
                fn()
            times[name].append((time.process_time() - t0) / n)
    return {name: statistics.median(ts) for name, ts in times.items()}


def _rel(a, b) -> float:
    b = float(b)
    return abs(float(a) / b - 1.0) if b != 0 else abs(float(a))


def _peer_case(pot, m, v0, law):
    """Arguments of `peer.solve_dop853` but the tolerances, and a call at one rtol."""
    el = peer.elastic_table(pot)
    da, zeta = peer.damping_table(pot, law)
    q_scale = pot.turning_point(0.5 * m * v0 * v0, check=False)
    t_bound = 50.0 * q_scale / v0
    out = np.empty(len(peer.OUT_FIELDS))

    def call(rtol):
        return peer.solve_dop853(
            m, v0, zeta, el, da, rtol, rtol * q_scale, rtol * v0, t_bound, 0.0, out
        )

    return call


def _peer_outputs(out, v0) -> dict:
    return {
        "contact_time": out[0],
        "restitution": -out[1] / v0,
        "contact_time_zero_force": out[2],
        "restitution_zero_force": -out[3] / v0,
        "max_penetration": out[4],
        "peak_force": out[6],
    }


def _peer_ladder(call, v0, truth: dict, keys, target: float) -> dict:
    """Error of each rung; the cheapest rung at <= target (fewest evaluations), or the best."""
    rungs = []
    for rtol in PEER_RTOLS:
        out = call(rtol)
        if out[8] != 0.0:
            continue
        got = _peer_outputs(out, v0)
        err = max(_rel(got[k], truth[k]) for k in keys)
        rungs.append({"rtol": rtol, "max_rel_error": err, "nfev": int(out[7])})
    if not rungs:
        raise RuntimeError("the compiled DOP853 peer reached no end of contact on any rung")
    ok = [r for r in rungs if r["max_rel_error"] <= target]
    if ok:
        pick = min(ok, key=lambda r: r["nfev"])
        return {**pick, "at_equal_error": True, "ladder": rungs}
    pick = min(rungs, key=lambda r: r["max_rel_error"])
    return {**pick, "at_equal_error": False, "ladder": rungs}


def _prepared(pot, m):
    try:
        from reference_impl import prepare
    except ImportError:
        return None
    return prepare(pot, m)


def _compiled_only(prep, v0, zeta):
    """The one compiled call a prepared call makes at (v0, zeta), alone, or None.

    Timed beside the whole call, it says how much of a row's time is compiled work and
    how much is Python around it (why a goal is or is not in reach). It reads the
    prepared solver's private state, so it follows `reference_impl.exact.prepared`.
    None also where the prepared call does not answer from that call (zeta >= 0.9, a
    sum whose terms hand over inside the contact, a rule or check that refuses): a
    time of a call the prepared call does not make, or that does not answer, would
    misstate where its time goes.
    """
    from reference_impl.exact._branches import _GJ_ZETA_MAX
    from reference_impl.exact._prepared_kernel import power_call

    if not 0.0 <= zeta < _GJ_ZETA_MAX:
        return None  # the prepared call hands over to solve_impact
    if prep._c is not None:
        c, u, w = prep._c, prep._u, prep._W

        def call():
            return power_call(v0, zeta, c, u, w)

    elif prep._family is not None:
        prep(v0, zeta)  # keeps this speed's validated top and split decision
        q_top, off = prep._tops[v0]
        if off:
            return None  # the split path: solve_impact
        fam, args = prep._family, prep._args

        def call():
            return fam(v0, zeta, q_top, *args)

    else:
        return None
    return call if call()[-1] == 1.0 else None  # last: the call's status, 1.0 answered


_UNIVERSAL_KEYS = (
    "contact_time",
    "restitution",
    "contact_time_zero_force",
    "restitution_zero_force",
    "max_penetration",
)


def _family_row(name, pot, m, v0, blocks, impacts=IMPACTS, mp_subset=MP_SUBSET):
    zeta = FAMILY_ZETA
    t0 = time.perf_counter()
    sol = solve_impact(pot, m, v0, zeta)
    first = time.perf_counter() - t0
    truth = solve_impact_mp(pot, m, v0, zeta, dps=TRUTH_DPS)
    errs = {k: _rel(getattr(sol, k), truth[k]) for k in _UNIVERSAL_KEYS}
    ours_err = max(errs.values())
    target = max(ours_err, EQUAL_ERROR_FLOOR)
    cols, calls, eqset = _peer_columns(
        f"family {name}",
        pot,
        m,
        v0,
        {"law": "universal", "zeta": zeta},
        truth,
        _UNIVERSAL_KEYS,
        target,
        ours=lambda v, law: solve_impact(pot, m, v, law["zeta"]),
        truth_mp=lambda v, law: solve_impact_mp(pot, m, v, law["zeta"], dps=TRUTH_DPS),
        bound_ok=universal_bound_ok,
        rtols=PEER_RTOLS,
        impacts=impacts,
        mp_subset=mp_subset,
    )
    contestants = {
        "ours": lambda: solve_impact(pot, m, v0, zeta),
        "scipy": lambda: scipy_dop853(pot, m, v0, zeta, SCIPY_RTOL),
        **{f"peer:{k}": c for k, c in calls.items()},
    }
    prep = _prepared(pot, m)
    kernel = None if prep is None else _compiled_only(prep, v0, zeta)
    if prep is not None:
        contestants["prepared"] = lambda: prep(v0, zeta)
        identical = prep(v0, zeta) == sol and all(
            getattr(prep(v0, zeta), k) == getattr(sol, k) for k in _UNIVERSAL_KEYS
        )
    if kernel is not None:
        contestants["kernel"] = kernel
    t = _interleaved(contestants, blocks)
    row = {
        "scene": name,
        "potential": repr(pot),
        "m": m,
        "v0": v0,
        "zeta": zeta,
        "first_call_s": first,
        "ours_us": t["ours"] * 1e6,
        "ours_rel_errors": errs,
        "ours_max_rel_error": ours_err,
        "ours_reported_bound_rel": sol.quadrature_error / sol.contact_time,
        **fastest(cols, t),
        "scipy_us": t["scipy"] * 1e6,
        "scipy_rtol": SCIPY_RTOL,
        "equal_error_set": eqset,
    }
    row["ratio"] = row["peer_us"] / row["ours_us"]
    if prep is not None:
        row["prepared_us"] = t["prepared"] * 1e6
        row["prepared_identical"] = bool(identical)
        row["prepared_ratio"] = row["peer_us"] / row["prepared_us"]
    fast_us = row.get("prepared_us", row["ours_us"])
    ratio = row.get("prepared_ratio", row["ratio"])
    row["goal"] = f"<= {GOAL_US:g} us and >= {GOAL_RATIO_UNIVERSAL:g}x at <= 1e-14"
    row["goal_met"] = bool(
        fast_us <= GOAL_US
        and ratio >= GOAL_RATIO_UNIVERSAL
        and ours_err <= EQUAL_ERROR_FLOOR
        and row["peer_at_equal_error"]
        and set_ok(eqset)
        and row.get("prepared_identical", True)  # a fast call must answer as solve_impact
    )
    # By how much, and where the time goes: the compiled call alone (None: the call
    # took no single compiled path) against the whole prepared call.
    row["kernel_us"] = t["kernel"] * 1e6 if kernel is not None else None
    row["time_over_goal"] = fast_us / GOAL_US
    row["ratio_short_of_goal"] = GOAL_RATIO_UNIVERSAL / ratio
    return row


_LAW_KEYS = (*_UNIVERSAL_KEYS, "peak_force")


def _law_row(name, law, blocks, impacts=IMPACTS, mp_subset=MP_SUBSET):
    pot, m = hertz()
    v0 = LAW_V0
    t0 = time.perf_counter()
    sol = solve_law_impact(pot, m, v0, law)
    first = time.perf_counter() - t0
    truth = solve_law_impact_mp(pot, m, v0, law, dps=TRUTH_DPS)
    errs = {k: _rel(getattr(sol, k), truth[k]) for k in _LAW_KEYS}
    ours_err = max(errs.values())
    cols, calls, eqset = _peer_columns(
        f"law {name}",
        pot,
        m,
        v0,
        law,
        truth,
        _LAW_KEYS,
        max(ours_err, EQUAL_ERROR_FLOOR),
        ours=lambda v, lw: solve_law_impact(pot, m, v, lw),
        truth_mp=lambda v, lw: solve_law_impact_mp(pot, m, v, lw, dps=TRUTH_DPS),
        bound_ok=law_bound_ok,
        rtols=PEER_RTOLS,
        impacts=impacts,
        mp_subset=mp_subset,
    )
    # The prepared call (the law planned once per potential, mass and law), as the
    # universal rows' `prepare`: bit for bit the one-shot answer (checked here and tested).
    prep = prepare_law(pot, m, law)
    identical = prep(v0).to_dict() == sol.to_dict()
    t = _interleaved(
        {
            "ours": lambda: solve_law_impact(pot, m, v0, law),
            "prepared": lambda: prep(v0),
            "scipy": lambda: scipy_dop853(pot, m, v0, law, SCIPY_RTOL),
            **{f"peer:{k}": c for k, c in calls.items()},
        },
        blocks,
    )
    fast = fastest(cols, t)
    ratio = fast["peer_us"] / (t["ours"] * 1e6)
    prepared_ratio = fast["peer_us"] / (t["prepared"] * 1e6)
    return {
        "law": name,
        "damping": law,
        "potential": repr(pot),
        "m": m,
        "v0": v0,
        "first_call_s": first,
        "ours_us": t["ours"] * 1e6,
        "ours_rel_errors": errs,
        "ours_max_rel_error": ours_err,
        "ours_reported_bound_rel": sol.error_time / sol.contact_time,
        **fast,
        "ratio": ratio,
        "scipy_us": t["scipy"] * 1e6,
        "scipy_rtol": SCIPY_RTOL,
        "prepared_us": t["prepared"] * 1e6,
        "prepared_identical": bool(identical),
        "prepared_ratio": prepared_ratio,
        "equal_error_set": eqset,
        "goal": f">= {GOAL_RATIO_LAW:g}x at equal error (prepared call)",
        "goal_met": bool(
            prepared_ratio >= GOAL_RATIO_LAW and fast["peer_at_equal_error"] and set_ok(eqset)
        ),
    }


def _wall_median(fn, blocks):
    fn()
    ts = []
    for _ in range(blocks):
        t0 = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t0)
    return statistics.median(ts)


def batch_workloads():
    """The batch rows' workloads: (label, impacts per call, call, whether the row is
    compared with the single-impact peer). `benchmarks.bench_batch_phases` times the same."""
    pot, m = PowerLaw(1.0e9, 1.5), 0.0041
    rng = np.random.default_rng(12345)
    v = 10.0 ** rng.uniform(-1.0, 1.0, BATCH_N)
    z = rng.uniform(0.0, BATCH_ZETA_MAX, BATCH_N)
    zg = np.repeat(np.linspace(0.0, BATCH_ZETA_MAX, GRID_ZETAS), GRID_SPEEDS)
    vg = np.tile(np.logspace(-1.0, 1.0, GRID_SPEEDS), GRID_ZETAS)
    vl = np.logspace(-1.0, 1.0, LAW_BATCH_N)
    return (
        (
            f"Hertz, {BATCH_N} impacts, distinct zeta in [0, {BATCH_ZETA_MAX}]",
            BATCH_N,
            lambda: solve_impacts(pot, m, v, z),
            True,
        ),
        (
            f"Hertz, grid {GRID_ZETAS} zeta x {GRID_SPEEDS} v0",
            vg.size,
            lambda: solve_impacts(pot, m, vg, zg),
            True,
        ),
        # A new potential each call: each call pays the validation of its turning points,
        # as a user's first batch on a potential does (results do not depend on it).
        (
            f"Hertz + {LAW_BATCH}, {LAW_BATCH_N} speeds (general-law batch)",
            LAW_BATCH_N,
            lambda: solve_impacts(PowerLaw(1.0e9, 1.5), m, vl, law=LAW_BATCH),
            False,
        ),
    )


def _batch_rows(blocks, peer_us):
    """`solve_impacts` on Hertz, one thread against every core (wall time, interleaved)."""
    import numba

    # Every core numba may use (NUMBA_NUM_THREADS, the machine's count by default).
    cores = numba.config.NUMBA_NUM_THREADS
    workloads = [
        (label, size, call, peer_us if with_peer else None)
        for label, size, call, with_peer in batch_workloads()
    ]
    rows = []
    for label, size, call, peer_one in workloads:
        per = {1: [], cores: []}
        cpu1 = []
        res = {}
        for threads in (1, cores):
            numba.set_num_threads(threads)
            res[threads] = call()  # warm
        for _ in range(blocks):
            for threads in (1, cores):
                numba.set_num_threads(threads)
                c0, t0 = time.process_time(), time.perf_counter()
                call()
                per[threads].append(time.perf_counter() - t0)
                if threads == 1:
                    cpu1.append(time.process_time() - c0)
        numba.set_num_threads(cores)
        t1, tn = statistics.median(per[1]), statistics.median(per[cores])
        speedup = t1 / tn
        identical = all(np.array_equal(res[1][k], res[cores][k], equal_nan=True) for k in res[1])
        rows.append(
            {
                "workload": label,
                "threads": cores,
                "us_per_impact_1_thread": t1 / size * 1e6,
                "cpu_us_per_impact_1_thread": statistics.median(cpu1) / size * 1e6,
                "us_per_impact_all_threads": tn / size * 1e6,
                "impacts_per_s": size / tn,
                "parallel_speedup": speedup,
                "bit_identical_to_1_thread": bool(identical),
                "ratio_vs_peer_single_impact": (
                    None if peer_one is None else peer_one / (tn / size * 1e6)
                ),
                "goal": f">= {GOAL_PARALLEL:g}x one thread on 2 cores",
                "goal_met": bool(identical and speedup >= GOAL_PARALLEL),
                # Amdahl's serial part the speedup implies: S = 1 / (s + (1 - s) / n).
                "implied_serial_fraction": (
                    (cores / speedup - 1.0) / (cores - 1.0) if cores > 1 else None
                ),
                "load_average_1min": _load(),
            }
        )
    return rows


def run(blocks: int = 7, impacts: int = IMPACTS, mp_subset: int = MP_SUBSET) -> dict:
    load_before = _load()
    families = [
        _family_row(sc.name, sc.potential, sc.m, sc.v0, blocks, impacts, mp_subset)
        for sc in family_scenes()
    ]
    laws = [
        _law_row(name, law, blocks, impacts, mp_subset)
        for name, law in calibrated_laws().items()
        if name != "universal"
    ]
    batch = _batch_rows(blocks, families[0]["peer_us"])
    return {
        "schema": SCHEMA,
        "families": families,
        "laws": laws,
        "batch": batch,
        "truth": f"solve_impact_mp / solve_law_impact_mp, {TRUTH_DPS} digits",
        "truth_dps": TRUTH_DPS,
        "peer_rtols": list(PEER_RTOLS),
        "equal_error": (
            f"peer's largest relative error over every output and each of {impacts} random "
            f"impacts <= max(ours, {EQUAL_ERROR_FLOOR:g}); truth of the set: ours, checked "
            f"against the {TRUTH_DPS}-digit truth on {mp_subset} of them"
        ),
        "peers": list(PEERS),
        "numbalsoda": numbalsoda_note(),
        "timing": f"CPU time (process_time), {blocks} interleaved blocks, median; batch: wall",
        "blocks": blocks,
        "load_average_1min": load_before,
        "load_average_1min_after": _load(),
        "machine": machine_info(),
        "goal_met": all(r["goal_met"] for r in families),
        "law_goal_met": all(r["goal_met"] for r in laws),
        "batch_goal_met": all(b["goal_met"] for b in batch),
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", help="also write the result to this JSON file")
    ap.add_argument(
        "--blocks", type=int, default=7, help="interleaved blocks (median; 1 for a quick check)"
    )
    ap.add_argument(
        "--impacts", type=int, default=IMPACTS, help=f"random impacts per row (>= {IMPACTS})"
    )
    ap.add_argument(
        "--mp-subset",
        type=int,
        default=MP_SUBSET,
        help=f"of them checked against the 30-digit truth (>= {MP_SUBSET})",
    )
    args = ap.parse_args(argv)
    for flag, value, low in (
        ("--blocks", args.blocks, 1),
        ("--impacts", args.impacts, 1),
        ("--mp-subset", args.mp_subset, 1),
    ):
        if value < low:
            print(f"bench_exact: error: {flag} {value}: at least {low}", file=sys.stderr)
            return 2
    res = run(args.blocks, args.impacts, args.mp_subset)
    print_result(res)
    if args.json:
        write_json(args.json, res, default=_json_default)
    return 0


def _json_default(x):
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, float) and not math.isfinite(x):
        return None
    raise TypeError(f"not JSON: {x!r}")


if __name__ == "__main__":
    raise SystemExit(main())
