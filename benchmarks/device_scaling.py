"""Scaling on a many-core machine (issue 27, goals 4 and 5): one script, one JSON.

Run (from the repository root; dask and distributed importable):

    PYTHONPATH=$PWD python benchmarks/device_scaling.py --out DIR

Sections, each in its own time budget, each recording its error and letting the next
one run, the JSON rewritten after each (a run stopped midway keeps what it measured):

1. ``impacts``: `solve_impacts` on Hertz at 1, 2, 4, 8, 16 numba threads (those the
   machine has), three workloads: 1e5 impacts with distinct zetas (the Gauss-Jacobi sums
   dominate), the grid 50 zetas x 2000 speeds of `bench_exact` (the per-impact fill
   dominates) and a grid 50 x 20000. Wall time, median of blocks interleaved over the
   thread counts; every thread count's arrays compared with one thread's, bit for bit.
2. ``law``: `solve_impacts(..., law=Hunt-Crossley)` (the general-law batch) likewise, on
   rising speeds (once each a new energy record with a serial validated top per speed;
   now all tops come from one vectorised inverse) and on the same speeds shuffled.
3. ``sweep``: the 480-case dt-crit map of `benchmarks.bench_sweep` (16 exponents x 30
   masses) through the engine of ``hcv sweep`` on local clusters of 1, 2, 16, 8, 4
   workers (one numba thread each); `bench_sweep._fit` fits fixed + per worker + per
   case to the 1- and 2-worker runs, and each N's measured time (start + cases +
   close) is set beside the prediction. A worker count whose predicted time does not
   fit in what is left of the budget is skipped (said so).

Top-level imports are the standard library only: the local cluster's processes are
spawned and import this file as their ``__main__``.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
import traceback
from pathlib import Path

_THREADS = (1, 2, 4, 8, 16)
_WORKERS = (1, 2, 16, 8, 4)  # the model's two points first, then the cheapest
_BUDGET_S = {"impacts": 100.0, "law": 50.0, "sweep": 330.0}
_MIN_BLOCKS = 3


def _say(msg: str) -> None:
    print(f"[{time.strftime('%H:%M:%S')}] {msg}", flush=True)


def _load() -> list[float] | None:
    try:
        return [round(x, 2) for x in os.getloadavg()]
    except OSError:
        return None


def _machine() -> dict:
    info: dict = {"load": _load()}
    try:
        from reference_impl.provenance import machine_info

        info.update(machine_info())
    except Exception as exc:  # noqa: BLE001 - recorded, not fatal
        info["machine_info_error"] = repr(exc)
    try:
        info["affinity_cpus"] = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        pass
    try:
        import psutil

        info["physical_cores"] = psutil.cpu_count(logical=False)
    except Exception:  # noqa: BLE001
        pass
    try:
        import numba

        info["numba"] = numba.__version__
        info["numba_num_threads"] = numba.config.NUMBA_NUM_THREADS
    except Exception as exc:  # noqa: BLE001
        info["numba_error"] = repr(exc)
    return info


def _same_bits(a: dict, b: dict) -> bool:
    return a.keys() == b.keys() and all(
        a[k].shape == b[k].shape and a[k].tobytes() == b[k].tobytes() for k in a
    )


def _thread_scaling(label: str, call, threads, budget: float, blocks: int) -> dict:
    """Median wall time of ``call()`` per numba thread count, blocks interleaved."""
    import numba

    t_start = time.perf_counter()
    ref = None
    row: dict = {"workload": label, "threads": {}}
    outs = {}
    for t in threads:
        numba.set_num_threads(t)
        outs[t] = call()  # warm (compiles on the first call)
    ref = outs[threads[0]]
    times: dict = {t: [] for t in threads}
    for b in range(blocks):
        if b >= _MIN_BLOCKS and time.perf_counter() - t_start > budget:
            row["note"] = f"stopped after {b} blocks (budget {budget:.0f} s)"
            break
        for t in threads:
            numba.set_num_threads(t)
            t0 = time.perf_counter()
            call()
            times[t].append(time.perf_counter() - t0)
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    t1 = statistics.median(times[threads[0]])
    for t in threads:
        med = statistics.median(times[t])
        row["threads"][t] = {
            "wall_s": med,
            "speedup": t1 / med,
            "efficiency": t1 / med / t,
            "blocks": len(times[t]),
            "bit_identical_to_1_thread": _same_bits(outs[t], ref),
        }
    row["seconds"] = time.perf_counter() - t_start
    _say(
        f"{label}: "
        + ", ".join(
            f"{t} thr {r['wall_s'] * 1e3:.1f} ms ({r['speedup']:.2f}x"
            f"{'' if r['bit_identical_to_1_thread'] else ', NOT identical'})"
            for t, r in row["threads"].items()
        )
    )
    return row


def _threads_available(wanted) -> list[int]:
    import numba

    return [t for t in wanted if t <= numba.config.NUMBA_NUM_THREADS]


def _section_impacts(args, budget: float) -> dict:
    import numpy as np

    from reference_impl import PowerLaw, solve_impacts

    pot, m = PowerLaw(1.0e9, 1.5), 0.0041
    rng = np.random.default_rng(12345)
    n = args.impacts
    v = 10.0 ** rng.uniform(-1.0, 1.0, n)
    z = rng.uniform(0.0, 0.85, n)
    grids = []
    for nz, nv in ((50, n // 50), (50, 10 * n // 50)):
        grids.append(
            (
                f"Hertz, grid {nz} zeta x {nv} v0",
                np.tile(np.logspace(-1.0, 1.0, nv), nz),
                np.repeat(np.linspace(0.0, 0.85, nz), nv),
            )
        )
    work = [(f"Hertz, {n} impacts, distinct zeta in [0, 0.85]", v, z), *grids]
    threads = _threads_available(args.threads)
    rows = []
    t0 = time.perf_counter()
    for i, (label, vs, zs) in enumerate(work):
        left = budget - (time.perf_counter() - t0)
        share = left / (len(work) - i)
        try:
            rows.append(
                _thread_scaling(
                    label,
                    lambda vs=vs, zs=zs: solve_impacts(pot, m, vs, zs),
                    threads,
                    share,
                    args.blocks,
                )
            )
        except Exception:  # noqa: BLE001 - recorded; the next workload runs
            rows.append({"workload": label, "error": traceback.format_exc(limit=4)})
            _say(f"{label}: error\n{rows[-1]['error']}")
    return {"rows": rows, "impacts": n, "thread_counts": threads}


def _section_law(args, budget: float) -> dict:
    import numpy as np

    from reference_impl import PowerLaw, solve_impacts

    law = {"law": "hunt-crossley", "alpha": 0.37}
    m = 0.0041
    v = np.logspace(-1.0, 1.0, args.law_speeds)
    threads = _threads_available(args.threads)
    # A new potential each call: the general law's error_time depends on the validated
    # tops cached per potential object by earlier calls (`_validate._validated_top`).
    # Rising speeds each set a new energy record (one serial `_validated_top` call per
    # speed); shuffled ones few (the compiled integrations alone are spread).
    shuffled = np.random.default_rng(2027).permutation(v)
    rows = []
    for label, vs in (("rising", v), ("shuffled", shuffled)):
        try:
            rows.append(
                _thread_scaling(
                    f"Hertz + {law}, {v.size} speeds, {label}",
                    lambda vs=vs: solve_impacts(PowerLaw(1.0e9, 1.5), m, vs, law=law),
                    threads,
                    budget / 2,
                    args.blocks,
                )
            )
        except Exception:  # noqa: BLE001 - recorded; the next workload runs
            rows.append({"workload": label, "error": traceback.format_exc(limit=4)})
            _say(f"law {label}: error\n{rows[-1]['error']}")
    return {"rows": rows, "thread_counts": threads}


def _section_sweep(args, budget: float, res: dict, out: Path) -> dict:
    from benchmarks import bench_sweep as bs

    t_start = time.perf_counter()
    payloads = bs._payloads(args.masses)
    n = len(payloads)
    sec: dict = {"cases": n, "runs": {}, "skipped": {}, "errors": {}}
    res["sections"]["sweep"] = sec
    t = time.perf_counter()
    bs._warm()  # numba kernels compiled (and cached) here once, before any worker loads them
    sec["warm_main_s"] = time.perf_counter() - t
    _say(f"sweep: {n} cases; kernels warmed in {sec['warm_main_s']:.1f} s")
    fit = None
    ref_ratios = None
    for w in args.workers:
        left = budget - (time.perf_counter() - t_start)
        if fit is not None:
            need = 1.3 * bs._predict(fit, w, n) + 5.0
            if need > left:
                sec["skipped"][w] = f"predicted {need:.0f} s (x1.3 + 5 s) > {left:.0f} s left"
                _say(f"sweep: {w} workers skipped: {sec['skipped'][w]}")
                continue
        elif w > 2 or left <= 0:
            sec["skipped"][w] = "no model (the 1- or 2-worker run is missing)"
            continue
        try:
            _say(f"sweep: {w} workers ...")
            r = bs._cluster_run(w, payloads, f"w{w}")
            ratios = r.pop("ratios")
            if ref_ratios is None:
                ref_ratios = ratios
            r["identical_to_first_run"] = ratios == ref_ratios
            r["measured_total_s"] = r["startup_s"] + r["wall_s"] + r["close_s"]
            r["in_case_s_per_case"] = r["in_case_s"] / n
            r["busy"] = r["in_case_s"] / (w * r["wall_s"])
            sec["runs"][w] = r
            _say(
                f"sweep: {w} workers: start {r['startup_s']:.1f} s, cases {r['wall_s']:.1f} s, "
                f"close {r['close_s']:.1f} s; {r['in_case_s_per_case'] * 1e3:.0f} ms in a case; "
                f"busy {r['busy']:.0%}; identical {r['identical_to_first_run']}"
            )
        except Exception:  # noqa: BLE001 - recorded; the next worker count runs
            sec["errors"][w] = traceback.format_exc(limit=6)
            _say(f"sweep: {w} workers: error\n{sec['errors'][w]}")
        if fit is None and 1 in sec["runs"] and 2 in sec["runs"]:
            fit = bs._fit(sec["runs"], n)
            sec["model"] = {k: v for k, v in fit.items() if k != "fixed"}
        _write(res, out)
    if fit is not None:
        one = sec["runs"][1]["measured_total_s"]
        sec["table"] = {
            w: {
                "measured_s": r["measured_total_s"],
                "predicted_s": bs._predict(fit, w, n),
                "measured_over_predicted": r["measured_total_s"] / bs._predict(fit, w, n),
                "speedup_over_1_worker": one / r["measured_total_s"],
                "case_slowdown_vs_1_worker": r["in_case_s_per_case"]
                / sec["runs"][1]["in_case_s_per_case"],
            }
            for w, r in sorted(sec["runs"].items())
        }
        for w, row in sec["table"].items():
            _say(
                f"sweep model: {w} workers measured {row['measured_s']:.1f} s, predicted "
                f"{row['predicted_s']:.1f} s ({row['measured_over_predicted']:.2f}); "
                f"{row['speedup_over_1_worker']:.2f}x one worker; a case "
                f"{row['case_slowdown_vs_1_worker']:.2f}x its 1-worker time"
            )
    return sec


def _write(res: dict, out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    path = out / "device_scaling.json"
    path.write_text(json.dumps(res, indent=2, default=_json_default) + "\n", encoding="utf-8")


def _json_default(x):
    try:
        return x.item()  # numpy scalars
    except AttributeError:
        return repr(x)


def _ints(text: str) -> tuple[int, ...]:
    try:
        vals = tuple(int(x) for x in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"not a comma-separated list of integers: {text!r}"
        ) from None
    if not vals or min(vals) < 1:
        raise argparse.ArgumentTypeError(f"counts must be >= 1, got {text!r}")
    return vals


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True, help="directory of device_scaling.json")
    ap.add_argument("--threads", type=_ints, default=_THREADS, help="numba thread counts")
    ap.add_argument("--workers", type=_ints, default=_WORKERS, help="sweep worker counts")
    ap.add_argument("--impacts", type=int, default=100_000, help="impacts per workload")
    ap.add_argument("--law-speeds", type=int, default=4000, help="speeds of the law batch")
    ap.add_argument("--masses", type=int, default=30, help="masses per exponent (30: 480)")
    ap.add_argument("--blocks", type=int, default=7, help="interleaved blocks (median)")
    ap.add_argument("--scale", type=float, default=1.0, help="multiply every budget")
    ap.add_argument("--sections", default="impacts,law,sweep", help="which sections")
    args = ap.parse_args(argv)
    if 1 not in args.threads or args.threads[0] != 1:
        ap.error(f"--threads must start with 1 (the reference), got {args.threads}")
    out = Path(args.out)
    t0 = time.perf_counter()
    res: dict = {"argv": sys.argv[1:], "started": time.strftime("%Y-%m-%dT%H:%M:%S%z")}
    res["machine"] = _machine()
    res["sections"] = {}
    _say(f"machine: {json.dumps(res['machine'], default=str)[:600]}")
    _write(res, out)
    wanted = [s.strip() for s in args.sections.split(",") if s.strip()]
    for name in wanted:
        budget = _BUDGET_S.get(name, 60.0) * args.scale
        t = time.perf_counter()
        _say(f"section {name}: budget {budget:.0f} s; load {_load()}")
        try:
            if name == "impacts":
                res["sections"][name] = _section_impacts(args, budget)
            elif name == "law":
                res["sections"][name] = _section_law(args, budget)
            elif name == "sweep":
                _section_sweep(args, budget, res, out)
            else:
                res["sections"][name] = {"error": f"unknown section {name!r}"}
        except Exception:  # noqa: BLE001 - recorded; the next section runs
            sec = res["sections"].setdefault(name, {})
            sec["error"] = traceback.format_exc(limit=6)
            _say(f"section {name}: error\n{sec['error']}")
        res["sections"].setdefault(name, {})["section_s"] = time.perf_counter() - t
        res["sections"][name]["load_after"] = _load()
        _write(res, out)
    res["total_s"] = time.perf_counter() - t0
    res["load_end"] = _load()
    _write(res, out)
    _say(f"done in {res['total_s']:.0f} s: {out / 'device_scaling.json'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
