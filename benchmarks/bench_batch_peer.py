"""`solve_impacts` against the strongest peer run in a compiled parallel loop (issue 38, goal 5).

Goal: `reference_impl.solve_impacts`, the universal law and a general law, >= `GOAL_RATIO`
times as fast as the fastest peer at equal error run in a compiled parallel loop over the
same impacts (`benchmarks.peer_batch`: each impact the serial peer's very call, one per
thread step of a numba ``prange`` loop), on 1 and on 2 threads (`numba.set_num_threads`).

Rows (`ROWS`), each over the same `IMPACTS` impacts for ours and the peers:

* ``universal``: Hertz (k = 1e9, m = 0.0041 kg), speeds log-uniform in 0.1 .. 10 m/s and
  a distinct zeta each, uniform in [0, 0.85]: `benchmarks.bench_exact`'s first batch
  workload (its seed, 12345), `solve_impacts(pot, m, v0s, zetas)`;
* ``linear`` and ``hunt-crossley``: the general-law batch, `solve_impacts(pot, m, v0s,
  law=...)`, on the law study's Hertz contact with its calibrated laws
  (`reference_impl.studies.laws.calibrated_laws`: e = 0.8 at 1 m/s), the linear dashpot
  and Hunt-Crossley; speeds log-uniform in 0.1 .. 10 m/s, seeded by the row's name.

Ours' rung: the loosest ``rtol`` of the short ladder `OURS_RTOLS` (None: full accuracy,
then 1e-12, 1e-11, ...; walked until the first rung over the floor) whose worst relative
error over the sample (against the proxy below, every output) is <= `EQUAL_ERROR_FLOOR`,
the freedom the work-precision bench gives ours (a looser rtol only lengthens the Taylor
kernel's steps). The ratio and the goal use ours at that rung; ours at full accuracy is
timed beside it and recorded with its own ratio (``ours_full``).

Equal error, as `benchmarks.bench_exact` chooses it (`benchmarks._equal_error.set_ladder`):
on a sample of `SAMPLE` impacts spread evenly over the batch, each peer's rung is the
cheapest of the ladder `bench_exact.PEER_RTOLS` whose WORST relative error over every
output (both ends' time and restitution, q_max; the peak force for a general law) and
every sampled impact is <= max(ours at its rung, `bench_exact.EQUAL_ERROR_FLOOR`), or its most
accurate rung (``peer_at_equal_error`` False) when none gets there. Truth: the proxy the
work-precision bench uses, ours one impact at a time (`solve_impact`, `solve_law_impact`),
checked against the 30-digit truth on the first `MP_SUBSET` sampled impacts
(`benchmarks._equal_error.check_proxy`); ours' batch error (at each rung) is its error
against that proxy over the sample. The parallel peer's rows are checked bit for bit against the serial
peer on the sample.

Timing: each contestant (ours at its rung, ours at full accuracy where that rung is
looser, each peer at its rung) called on the whole batch, in turn, at each thread count
(``--threads``, default 1 and 2), block after block (interleaved); wall and CPU time
(`time.process_time`, every thread of the process) of each call, median of the blocks.
The ratio is the peer's wall time over ours at the same thread count; the denominator is
the fastest peer at equal error on that many threads, else the most accurate. The record
(`SCHEMA`) holds the machine, the commit, the load average at the start and end of the
run and of each row.

Run: ``python -m benchmarks.bench_batch_peer [--json FILE] [--quick] [--impacts N]
[--blocks N] [--sample N] [--mp-subset N] [--threads 1,2,4,...]``: ~15 min on a quiet 2-core machine (the peers
take ~100-200 us an impact); ``--quick`` (`QUICK` impacts, 1 block, a sample of
`QUICK_SAMPLE`, `QUICK_MP` checked against mpmath) is a check that it runs, not a
measurement (< 60 s with a warm compile cache).
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import sys
import time
import zlib

import numba
import numpy as np

from reference_impl import PowerLaw, solve_impact, solve_impacts
from reference_impl.exact._general_law_mp import solve_law_impact_mp
from reference_impl.exact.general_law import solve_law_impact
from reference_impl.exact.solve import solve_impact_mp
from reference_impl.studies.laws import calibrated_laws, hertz

from ._equal_error import check_proxy, law_bound_ok, set_ladder, universal_bound_ok
from ._machine import machine_info
from ._peers import PEER_LABELS, outputs, peer_cases
from ._record import write_json
from .bench_exact import _UNIVERSAL_KEYS, EQUAL_ERROR_FLOOR, PEER_RTOLS, TRUTH_DPS
from .peer_batch import BATCH_PEERS, batch_call

__all__ = ["GOAL_RATIO", "OURS_RTOLS", "ROWS", "SCHEMA", "main", "run"]

# /2: ours timed at its rung of OURS_RTOLS (ours_rtol, ours_rungs) with full accuracy beside
# it (ours_full); the thread counts chosen (--threads).
SCHEMA = "hcv-bench-batch-peer/2"
GOAL_RATIO = 10.0  # issue 38, goal 5
ROWS = ("universal", "linear", "hunt-crossley")
IMPACTS = 100_000  # the batch
SAMPLE = 1000  # equal error over this many (`benchmarks._equal_error.IMPACTS`, the minimum)
MP_SUBSET = 50  # of them checked against the 30-digit truth (the minimum)
BLOCKS = 3
# Ours' ladder, most accurate first (None: full accuracy, ~1e-15; measured on 20 000 Hertz
# speeds against it: 1e-11 moves the outputs by at most 7e-15 (linear) / 1.4e-14 (HC)).
OURS_RTOLS = (None, 1e-12, 1e-11, 1e-10)
QUICK, QUICK_SAMPLE, QUICK_MP = 10_000, 100, 2
# The universal row: `benchmarks.bench_exact.batch_workloads`'s first workload.
_UNIVERSAL_POT, _UNIVERSAL_M, _SEED, _ZETA_MAX = PowerLaw(1.0e9, 1.5), 0.0041, 12345, 0.85
_LOG_V0 = (-1.0, 1.0)
# The outputs compared: bench_exact's (one list of what 'equal error' covers).
_LAW_KEYS = (*_UNIVERSAL_KEYS, "peak_force")


def _load() -> float | None:
    return os.getloadavg()[0] if hasattr(os, "getloadavg") else None


def _threads() -> tuple[int, ...]:
    """1 and 2 threads (1 alone where numba may use one): the default of ``--threads``."""
    return tuple(sorted({1, min(2, numba.config.NUMBA_NUM_THREADS)}))


def _parse_threads(text: str) -> tuple[int, ...]:
    """``--threads`` "1,2,4": sorted distinct counts, each 1 .. numba's thread pool; a bad
    count raises ValueError naming it."""
    top = numba.config.NUMBA_NUM_THREADS
    counts = set()
    for part in text.split(","):
        try:
            n = int(part)
        except ValueError:
            raise ValueError(f"--threads {text}: {part.strip()!r} is not a count") from None
        if not 1 <= n <= top:
            raise ValueError(f"--threads {text}: {n} outside 1 .. {top} (numba's threads)")
        counts.add(n)
    return tuple(sorted(counts))


def _parse_rows(text: str) -> tuple[str, ...]:
    """``--rows`` "linear,hunt-crossley": the rows in `ROWS`' order; an unknown name raises
    ValueError naming it."""
    names = [part.strip() for part in text.split(",")]
    for name in names:
        if name not in ROWS:
            raise ValueError(f"--rows {text}: {name!r} is not one of {', '.join(ROWS)}")
    return tuple(r for r in ROWS if r in names)


def workload(name: str, n: int) -> dict:
    """The row's potential, mass, speeds and damping (``zetas`` or ``law``), and its keys."""
    if name == "universal":
        rng = np.random.default_rng(_SEED)
        v = 10.0 ** rng.uniform(*_LOG_V0, n)
        z = rng.uniform(0.0, _ZETA_MAX, n)
        return {
            "pot": _UNIVERSAL_POT,
            "m": _UNIVERSAL_M,
            "v": v,
            "zetas": z,
            "law": None,
            "keys": _UNIVERSAL_KEYS,
        }
    if name not in ROWS:
        raise ValueError(f"row must be one of {ROWS}, got {name!r}")
    pot, m = hertz()
    rng = np.random.default_rng(zlib.crc32(name.encode()))
    v = 10.0 ** rng.uniform(*_LOG_V0, n)
    return {
        "pot": pot,
        "m": m,
        "v": v,
        "zetas": None,
        "law": calibrated_laws()[name],
        "keys": _LAW_KEYS,
    }


def _impact_law(w: dict, i: int) -> dict:
    return {"law": "universal", "zeta": float(w["zetas"][i])} if w["law"] is None else w["law"]


def _ours_call(w: dict, rtol: float | None = None):
    pot, m, v = w["pot"], w["m"], w["v"]
    if w["law"] is None:
        return lambda: solve_impacts(pot, m, v, w["zetas"], rtol=rtol)
    return lambda: solve_impacts(pot, m, v, law=w["law"], rtol=rtol)


def _ours_rung(w: dict, idx: np.ndarray, truths: np.ndarray, full: dict) -> tuple:
    """(rtol, its arrays, [{rtol, max_rel_error}] of the rungs tried): the loosest rung of
    `OURS_RTOLS`, walked from full accuracy to the first over `EQUAL_ERROR_FLOOR`, whose
    worst error over the sample is within it (full accuracy where none is)."""
    keys = w["keys"]
    pick, arrays, tried = None, full, []
    for rtol in OURS_RTOLS:
        got = full if rtol is None else _ours_call(w, rtol)()
        err = _rel(np.array([[float(got[k][i]) for k in keys] for i in idx]), truths)
        tried.append({"rtol": rtol, "max_rel_error": err})
        if err > EQUAL_ERROR_FLOOR:
            break
        pick, arrays = rtol, got
    return pick, arrays, tried


def _one(w: dict, i: int):
    """Ours one impact at a time (the proxy truth)."""
    v0, law = float(w["v"][i]), _impact_law(w, i)
    if w["law"] is None:
        return solve_impact(w["pot"], w["m"], v0, law["zeta"])
    return solve_law_impact(w["pot"], w["m"], v0, law)


def _truth_mp(w: dict):
    pot, m = w["pot"], w["m"]
    if w["law"] is None:
        return lambda v0, law: solve_impact_mp(pot, m, v0, law["zeta"], dps=TRUTH_DPS)
    return lambda v0, law: solve_law_impact_mp(pot, m, v0, law, dps=TRUTH_DPS)


def _rel(got: np.ndarray, truth: np.ndarray) -> float:
    """Largest relative error (inf where an output is missing)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        e = np.where(
            truth != 0.0, np.abs(got / np.where(truth != 0.0, truth, 1.0) - 1.0), np.abs(got)
        )
    e[np.isnan(e)] = np.inf
    return float(e.max()) if e.size else 0.0


def _equal_error(w: dict, idx: np.ndarray, ours: dict, mp_subset: int) -> dict:
    """The sample's proxy truth, ours' rung and batch error on it (``ours``: its arrays at
    full accuracy), the proxy's check, and each peer's rung at equal error (with its serial
    call at that rung, for the bit check)."""
    keys = w["keys"]
    sols = [_one(w, int(i)) for i in idx]
    truths = np.array([[float(getattr(s, k)) for k in keys] for s in sols])
    full_err = _rel(np.array([[float(ours[k][i]) for k in keys] for i in idx]), truths)
    ours_rtol, _arrays, rungs = _ours_rung(w, idx, truths, ours)
    ours_err = next(r["max_rel_error"] for r in rungs if r["rtol"] == ours_rtol)
    impacts = [(float(w["v"][i]), _impact_law(w, int(i))) for i in idx]
    subset = [(v, lw, s) for (v, lw), s in zip(impacts[:mp_subset], sols[:mp_subset], strict=True)]
    bound_ok = universal_bound_ok if w["law"] is None else law_bound_ok
    proxy = check_proxy(subset, _truth_mp(w), keys, bound_ok)
    target = max(ours_err, proxy["proxy_max_rel_error"], EQUAL_ERROR_FLOOR)
    cases = peer_cases(w["pot"], w["m"])
    peers = {}
    for name in BATCH_PEERS:
        if name not in cases:
            continue
        lad = set_ladder(cases[name], impacts, truths, keys, target, PEER_RTOLS)
        if lad is not None:
            peers[name] = {"label": PEER_LABELS[name], **lad, "serial": cases[name]}
    return {
        "impacts": impacts,
        "truths": truths,
        "ours_err": ours_err,
        "ours_full_err": full_err,
        "ours_rtol": ours_rtol,
        "ours_rungs": rungs,
        "proxy": proxy,
        "target": target,
        "peers": peers,
    }


def _timed(contestants: dict, threads: tuple, blocks: int) -> dict:
    """``{(name, threads): (median wall s, median CPU s)}``, interleaved block by block."""
    wall = {(c, t): [] for c in contestants for t in threads}
    cpu = {(c, t): [] for c in contestants for t in threads}
    for _ in range(blocks):
        for t in threads:
            numba.set_num_threads(t)
            for c, fn in contestants.items():
                c0, t0 = time.process_time(), time.perf_counter()
                fn()
                wall[(c, t)].append(time.perf_counter() - t0)
                cpu[(c, t)].append(time.process_time() - c0)
    numba.set_num_threads(max(threads))
    return {k: (statistics.median(wall[k]), statistics.median(cpu[k])) for k in wall}


def _denominator(peers: dict, th: str) -> str:
    """The fastest peer at equal error on ``th`` threads; else the most accurate."""
    ok = [k for k, p in peers.items() if p["at_equal_error"]]
    if ok:
        return min(ok, key=lambda k: peers[k]["wall_s"][th])
    return min(peers, key=lambda k: (peers[k]["max_rel_error"], peers[k]["wall_s"][th]))


def batch_row(
    name: str, n: int, blocks: int, sample: int, mp_subset: int, threads: tuple | None = None
) -> dict:
    """One row: ours and every parallel peer on the same ``n`` impacts (module docstring),
    on each count of ``threads`` (default `_threads`)."""
    load_start = _load()
    threads = threads or _threads()
    w = workload(name, n)
    ours = _ours_call(w)()  # compile and warm at full accuracy
    idx = np.unique(np.linspace(0, n - 1, min(sample, n)).astype(np.int64))
    eq = _equal_error(w, idx, ours, mp_subset)
    contestants, last = {"ours": _ours_call(w, eq["ours_rtol"])}, {}
    if eq["ours_rtol"] is not None:  # full accuracy timed beside the rung
        contestants["ours_full"] = _ours_call(w)
    for pname, p in eq["peers"].items():
        call = batch_call(pname, w["pot"], w["m"], w["v"], w["zetas"], w["law"])
        batch_call(
            pname, w["pot"], w["m"], w["v"][:8], None if w["law"] else w["zetas"][:8], w["law"]
        )(p["rtol"])  # compile / warm on a slice

        def fn(call=call, rtol=p["rtol"], pname=pname):
            last[pname] = call(rtol)

        contestants[f"peer:{pname}"] = fn
    t = _timed(contestants, threads, blocks)
    peers = {}
    for pname, p in eq["peers"].items():
        out = last[pname]
        serial = [p["serial"](v0, law)(p["rtol"]) for v0, law in eq["impacts"]]
        peers[pname] = {
            **{k: v for k, v in p.items() if k != "serial"},
            "wall_s": {str(th): t[(f"peer:{pname}", th)][0] for th in threads},
            "cpu_s": {str(th): t[(f"peer:{pname}", th)][1] for th in threads},
            "no_end": int(np.count_nonzero(out[:, 8] != 0.0)),
            "identical_to_serial_on_sample": bool(
                all(
                    np.array_equal(out[i], s, equal_nan=True)
                    for i, s in zip(idx, serial, strict=True)
                )
            ),
            "sample_max_rel_error_batch": _rel(
                np.array([[outputs(out[i], w["v"][i])[k] for k in w["keys"]] for i in idx]),
                eq["truths"],
            ),
        }
    full = "ours_full" if "ours_full" in contestants else "ours"
    row = {
        "row": name,
        "potential": repr(w["pot"]),
        "m": w["m"],
        "damping": w["law"] or {"law": "universal", "zeta": f"uniform [0, {_ZETA_MAX}]"},
        "impacts": n,
        "log10_v0_range": list(_LOG_V0),
        "threads": list(threads),
        "ours_rtol": eq["ours_rtol"],
        "ours_rungs": eq["ours_rungs"],
        "ours_wall_s": {str(th): t[("ours", th)][0] for th in threads},
        "ours_cpu_s": {str(th): t[("ours", th)][1] for th in threads},
        "ours_max_rel_error": eq["ours_err"],
        "ours_full": {
            "max_rel_error": eq["ours_full_err"],
            "wall_s": {str(th): t[(full, th)][0] for th in threads},
            "cpu_s": {str(th): t[(full, th)][1] for th in threads},
        },
        "equal_error_target": eq["target"],
        "sample": {
            "impacts": int(idx.size),
            "proxy_check": eq["proxy"],
            "truth": "ours one impact at a time (the proxy); checked against the "
            f"{TRUTH_DPS}-digit truth on the first {eq['proxy']['impacts']}",
        },
        "peers": peers,
    }
    return _verdict(row, load_start)


def _verdict(row: dict, load_start) -> dict:
    """The denominator and the ratio at each thread count (from the times above: the fastest
    peer on that many threads, so that a peer's luck on one count is not lent to the
    other), and the goal."""
    ours = row["ours_wall_s"]
    pick = {th: _denominator(row["peers"], th) for th in ours}
    p = {th: row["peers"][k] for th, k in pick.items()}
    ratio = {th: p[th]["wall_s"][th] / ours[th] for th in ours}
    ratio_cpu = {th: p[th]["cpu_s"][th] / row["ours_cpu_s"][th] for th in ours}
    full = row["ours_full"]  # ours at full accuracy against the same peers, for the record
    full = {
        **full,
        "us_per_impact": {th: 1e6 * full["wall_s"][th] / row["impacts"] for th in ours},
        "ratio": {th: p[th]["wall_s"][th] / full["wall_s"][th] for th in ours},
    }
    at_equal = any(q["at_equal_error"] for q in row["peers"].values())
    s = row["sample"]
    worst = min(ratio.values())
    # Why the goal is not met, each reason on its own (empty: met).
    reasons = [
        f"ratio {ratio[th]:.2f}x < {GOAL_RATIO:g}x on {th} thread(s)"
        for th in ratio
        if ratio[th] < GOAL_RATIO
    ]
    if not at_equal:
        best = min(q["max_rel_error"] for q in row["peers"].values())
        reasons.append(
            f"no peer reaches equal error (each compared at its most accurate rung: worst "
            f"error {best:.1e} at best > {row['equal_error_target']:.1e} over the sample)"
        )
    if not all(q["identical_to_serial_on_sample"] for q in row["peers"].values()):
        reasons.append("a parallel peer differs from the serial one")
    if s["impacts"] < SAMPLE or s["proxy_check"]["impacts"] < MP_SUBSET:
        reasons.append(
            f"equal error on {s['impacts']} impacts ({s['proxy_check']['impacts']} against "
            f"mpmath), fewer than {SAMPLE} ({MP_SUBSET}): a check, not a measurement"
        )
    if row["impacts"] < IMPACTS:
        reasons.append(f"{row['impacts']} impacts, not the issue's {IMPACTS}")
    if not s["proxy_check"]["bounds_held"]:
        reasons.append("ours broke its reported bound on the mpmath subset")
    n = row["impacts"]
    return {
        **row,
        "ours_full": full,
        "peer": pick,
        "peer_rtol": {th: q["rtol"] for th, q in p.items()},
        "peer_at_equal_error": at_equal,
        "peer_max_rel_error": {th: q["max_rel_error"] for th, q in p.items()},
        "ratio": ratio,
        "ratio_cpu": ratio_cpu,
        "us_per_impact": {th: 1e6 * ours[th] / n for th in ours},
        "peer_us_per_impact": {th: 1e6 * q["wall_s"][th] / n for th, q in p.items()},
        "goal": f">= {GOAL_RATIO:g}x the fastest parallel peer at equal error, every thread count",
        "goal_met": not reasons,
        "goal_not_met_because": reasons,
        "ratio_short_of_goal": GOAL_RATIO / worst,
        "load_average_1min": load_start,
        "load_average_1min_after": _load(),
    }


def run(
    impacts=IMPACTS, blocks=BLOCKS, sample=SAMPLE, mp_subset=MP_SUBSET, rows=ROWS, threads=None
) -> dict:
    """Every row of ``rows`` on each count of ``threads`` (default `_threads`); the record
    (format `SCHEMA`)."""
    load_before = _load()
    out = [batch_row(r, impacts, blocks, sample, mp_subset, threads) for r in rows]
    return {
        "schema": SCHEMA,
        "rows": out,
        "impacts": impacts,
        "blocks": blocks,
        "peers": list(BATCH_PEERS),
        "peer_rtols": list(PEER_RTOLS),
        "ours_rtols": list(OURS_RTOLS),
        "equal_error": (
            f"ours at the loosest rtol of {list(OURS_RTOLS)} within {EQUAL_ERROR_FLOOR:g}; "
            f"peer's largest relative error over every output and each of {sample} impacts "
            f"of the batch <= max(ours, {EQUAL_ERROR_FLOOR:g}); truth: ours one at a time, "
            f"checked against the {TRUTH_DPS}-digit truth on {mp_subset} of them"
        ),
        "timing": (
            f"wall and CPU time (process_time, all threads) of a call on the whole batch, "
            f"{blocks} interleaved block(s), median; ratio = peer wall / ours wall"
        ),
        "goal_ratio": GOAL_RATIO,
        "goal_met": all(r["goal_met"] for r in out),
        "load_average_1min": load_before,
        "load_average_1min_after": _load(),
        "machine": machine_info(),
    }


def print_result(res: dict) -> None:
    for r in res["rows"]:
        eq = "" if r["peer_at_equal_error"] else ", its best rung: never at equal error"
        for th in r["ratio"]:
            print(
                f"solve_impacts {r['row']}, {r['impacts']} impacts, {th} thread(s): ours"
                f" {r['us_per_impact'][th]:.2f} us/impact, {r['peer'][th]} (rtol"
                f" {r['peer_rtol'][th]:.0e}{eq}) {r['peer_us_per_impact'][th]:.1f}: ratio"
                f" {r['ratio'][th]:.1f}x (CPU {r['ratio_cpu'][th]:.1f}x); load"
                f" {r['load_average_1min']:.2f} -> {r['load_average_1min_after']:.2f}"
            )
        full = r["ours_full"]
        print(
            f"  ours at rtol {r['ours_rtol']} (loosest of {[g['rtol'] for g in r['ours_rungs']]}"
            f" within {EQUAL_ERROR_FLOOR:g}); at full accuracy "
            + ", ".join(
                f"{full['us_per_impact'][th]:.2f} us/impact, ratio {full['ratio'][th]:.1f}x on"
                f" {th} thread(s)"
                for th in full["ratio"]
            )
            + f", error {full['max_rel_error']:.1e}"
        )
        print(
            f"  errors over {r['sample']['impacts']} sampled: ours {r['ours_max_rel_error']:.1e}"
            f" (target {r['equal_error_target']:.1e}); "
            + "; ".join(
                f"{k} rtol {p['rtol']:.0e} {p['max_rel_error']:.1e}"
                f"{'' if p['at_equal_error'] else ' (best)'}, identical to serial:"
                f" {p['identical_to_serial_on_sample']}"
                for k, p in r["peers"].items()
            )
            + f"; goal {r['goal']}: {'met' if r['goal_met'] else 'NOT met'}"
            + ("" if r["goal_met"] else f" ({'; '.join(r['goal_not_met_because'])})")
        )
    mi = res["machine"]
    print(
        f"machine: {mi['platform']}, {mi['cpu_count']} cpus, load {res['load_average_1min']}"
        f" before, {res['load_average_1min_after']} after, commit {mi['commit']}"
    )


def _json_default(x):
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, float) and not math.isfinite(x):
        return None
    raise TypeError(f"not JSON: {x!r}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", help="also write the result to this JSON file")
    ap.add_argument(
        "--quick",
        action="store_true",
        help=f"{QUICK} impacts, 1 block, a sample of {QUICK_SAMPLE}, {QUICK_MP} against "
        "mpmath (a check that it runs); the flags below override",
    )
    ap.add_argument("--impacts", type=int, help=f"impacts per row (default {IMPACTS})")
    ap.add_argument("--blocks", type=int, help=f"interleaved blocks (default {BLOCKS})")
    ap.add_argument("--sample", type=int, help=f"impacts of the equal-error sample ({SAMPLE})")
    ap.add_argument("--mp-subset", type=int, help=f"of them against 30 digits ({MP_SUBSET})")
    ap.add_argument(
        "--threads", help=f"thread counts, e.g. 1,2,4,16 (default {','.join(map(str, _threads()))})"
    )
    ap.add_argument(
        "--rows",
        help=f"rows to run, comma-separated, of {','.join(ROWS)} (default all; a many-core "
        "run can leave out the universal row, whose peers take longest on one thread)",
    )
    args = ap.parse_args(argv)
    try:
        threads = _threads() if args.threads is None else _parse_threads(args.threads)
        rows = ROWS if args.rows is None else _parse_rows(args.rows)
    except ValueError as exc:
        print(f"bench_batch_peer: error: {exc}", file=sys.stderr)
        return 2
    quick = (
        (QUICK, 1, QUICK_SAMPLE, QUICK_MP) if args.quick else (IMPACTS, BLOCKS, SAMPLE, MP_SUBSET)
    )
    given = (args.impacts, args.blocks, args.sample, args.mp_subset)
    n, blocks, sample, mp = (d if g is None else g for g, d in zip(given, quick, strict=True))
    for flag, value in (
        ("--impacts", n),
        ("--blocks", blocks),
        ("--sample", sample),
        ("--mp-subset", mp),
    ):
        if value < 1:
            print(f"bench_batch_peer: error: {flag} {value}: at least 1", file=sys.stderr)
            return 2
    if mp > min(sample, n):
        print(
            f"bench_batch_peer: error: --mp-subset {mp}: at most the sample ({min(sample, n)})",
            file=sys.stderr,
        )
        return 2
    res = run(n, blocks, sample, mp, rows=rows, threads=threads)
    print_result(res)
    if args.json:
        write_json(args.json, res, default=_json_default)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
