"""Exact harmonic-map solver against scipy DOP853, every potential family, and the batch API.

Each row is one damped impact (universal law, zeta = 0.2): the exact solver and
DOP853 (rtol 1e-12, lean scalar right-hand side with the same damping law) are
timed in the same process (median of repeats) and scored against the mpmath
ground truth (`solve_impact_mp`, 30 digits). The batch rows time
`solve_impacts` on many Hertz impacts. The first-call time of each family
(numba compilation or on-disk cache load) is reported separately.

Goals (issue 9): every family <= 60 us per impact at <= 1e-13 relative error in
contact time and restitution and >= 300x DOP853; batch >= 1e5 Hertz impacts/s.

Law rows (issue 18): Hertz with each damping law of `reference_impl.theory.laws` (the
calibrated laws of `reference_impl.studies.laws`, e = 0.8 at 1 m/s), solved by
`reference_impl.exact.general_law` and by DOP853 (rtol 1e-12) with the same C(q), both
scored against the 30-digit Taylor truth (`solve_law_impact_mp`). Goal: <= 200 us
per impact at <= 1e-12 relative error (both ends, peak force) and >= 50x DOP853.

Run: ``python -m benchmarks.bench_exact [--json FILE] [--repeats N]``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import time

import numpy as np
import sympy as sp
from scipy.integrate import solve_ivp

from reference_impl import PowerLaw, solve_impact, solve_impacts
from reference_impl.exact._general_law_mp import solve_law_impact_mp
from reference_impl.exact._nodes import expression_sympy
from reference_impl.exact.general_law import solve_law_impact
from reference_impl.exact.solve import solve_impact_mp
from reference_impl.studies.laws import calibrated_laws, hertz
from reference_impl.studies.workprecision import FAMILY_ZETA, family_scenes
from reference_impl.theory.laws import law_from_dict

from ._machine import machine_info

ZETA = FAMILY_ZETA  # the damping of every family scene
RTOL_ODE = 1e-12
GOAL_US = 60.0
GOAL_SPEEDUP = 300.0
GOAL_ERROR = 1e-13
GOAL_BATCH = 1e5  # Hertz impacts per second per core
TRUTH_DPS = 30
# Batch workloads: random (v0, zeta) pairs with every zeta distinct, and a sweep
# grid of speeds at a few damping ratios (one oscillator sum per distinct zeta).
BATCH_N = 100_000
BATCH_ZETA_MAX = 0.85
GRID_ZETAS, GRID_SPEEDS = 50, 2000
# Issue 18: general damping laws on Hertz.
LAW_GOAL_US = 200.0
LAW_GOAL_SPEEDUP = 50.0
LAW_GOAL_ERROR = 1e-12
LAW_V0 = 1.0


def _scenes():
    """(name, potential, m, v0) of every family: the study's `family_scenes` (one home)."""
    return [(sc.name, sc.potential, sc.m, sc.v0) for sc in family_scenes()]


def _scalar_funcs(pot):
    """Lean scalar U and U' (math module) for the ODE right-hand side."""
    sym = expression_sympy(pot)
    if sym is not None:
        expr, dexpr, q = sym
        return sp.lambdify(q, expr, modules="math"), sp.lambdify(q, dexpr, modules="math")
    if isinstance(pot, PowerLaw):
        k, p = pot.k, pot.p
        return (lambda q: k * q ** (p + 1) / (p + 1)), (lambda q: k * q**p)
    if hasattr(pot, "terms"):
        fs = [_scalar_funcs(t) for t in pot.terms]
        return (lambda q: sum(f[0](q) for f in fs)), (lambda q: sum(f[1](q) for f in fs))
    a, Kn, al = pot._a, pot.Kn, pot.alpha
    c0 = math.pi * pot._bc / a**2

    def U(q):
        return Kn / (al + 1) * (c0 * (a * q * q - q**3 / 3)) ** (al + 1)

    def dU(q):
        return Kn * (c0 * (a * q * q - q**3 / 3)) ** al * c0 * (2 * a * q - q * q)

    return U, dU


def _dop853(pot, m, v0, zeta):
    """Contact time and restitution by DOP853 with the universal law
    C(q) = 2 zeta sqrt(m) U'(q) / sqrt(2 U(q)) (K = M = m)."""
    U, dU = _scalar_funcs(pot)
    c = 2.0 * zeta * math.sqrt(m)

    def rhs(t, y):
        q, v = y
        if q <= 0.0:
            return [v, 0.0]
        f = dU(q)
        return [v, -(f + c * f / math.sqrt(2.0 * U(q)) * v) / m]

    def touch(t, y):
        return y[0]

    touch.terminal, touch.direction = True, -1
    q_scale = pot.turning_point(0.5 * m * v0 * v0, check=False)
    t_end = 50.0 * q_scale / v0
    sol = solve_ivp(
        rhs,
        (0.0, t_end),
        [0.0, v0],
        method="DOP853",
        rtol=RTOL_ODE,
        atol=[RTOL_ODE * q_scale, RTOL_ODE * v0],
        events=touch,
    )
    return float(sol.t_events[0][0]), -float(sol.y_events[0][0][1]) / v0, int(sol.nfev)


def _median_time(fn, repeats: int, inner: int = 1) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(inner):
            fn()
        times.append((time.perf_counter() - t0) / inner)
    return statistics.median(times)


def _family_row(name, pot, m, v0, repeats):
    t0 = time.perf_counter()
    solve_impact(pot, m, v0, ZETA)
    first = time.perf_counter() - t0
    truth = solve_impact_mp(pot, m, v0, ZETA, dps=TRUTH_DPS)
    t_true, e_true = float(truth["contact_time"]), float(truth["restitution"])
    sol = solve_impact(pot, m, v0, ZETA)
    t_exact = _median_time(lambda: solve_impact(pot, m, v0, ZETA), repeats, inner=20)
    tc, e, nfev = _dop853(pot, m, v0, ZETA)
    t_ode = _median_time(lambda: _dop853(pot, m, v0, ZETA), max(3, repeats // 2))
    err_t = abs(sol.contact_time / t_true - 1)
    err_e = abs(sol.restitution / e_true - 1)
    row = {
        "family": name,
        "potential": repr(pot),
        "m": m,
        "v0": v0,
        "zeta": ZETA,
        "first_call_s": first,
        "exact_us": t_exact * 1e6,
        "exact_contact_time_rel_error": err_t,
        "exact_restitution_rel_error": err_e,
        "exact_reported_bound_rel": sol.quadrature_error / sol.contact_time,
        "dop853_us": t_ode * 1e6,
        "dop853_nfev": nfev,
        "dop853_contact_time_rel_error": abs(tc / t_true - 1),
        "dop853_restitution_rel_error": abs(e / e_true - 1),
        "speedup": t_ode / t_exact,
    }
    row["goal_met"] = bool(
        row["exact_us"] <= GOAL_US
        and row["speedup"] >= GOAL_SPEEDUP
        and max(err_t, err_e) <= GOAL_ERROR
    )
    return row


def _dop853_law(pot, m, v0, law):
    """DOP853 (rtol 1e-12) with C(q) of ``law`` (lean scalar right-hand side): contact time,
    restitution (q = 0 end), zero-force end time and restitution, peak force, nfev."""
    k, p = pot.k, pot.p
    dl = law_from_dict(law)
    terms = dl.terms()
    alpha, A = dl.alpha, dl.A

    def C(q):
        c = sum(cj * q**ej for cj, ej in terms)
        if alpha:
            c += alpha * k * q**p
        if A:
            c += A * k * p * q ** (p - 1)
        return c

    def rhs(t, y):
        q, v = y
        if q <= 0.0:
            return [v, 0.0]
        return [v, -(k * q**p + C(q) * v) / m]

    def touch(t, y):
        return y[0]

    def zero_force(t, y):
        q, v = y
        return k * max(q, 0.0) ** p + C(max(q, 0.0)) * v if t > 0 else 1.0

    touch.terminal, touch.direction = True, -1
    zero_force.direction = -1
    q_scale = pot.turning_point(0.5 * m * v0 * v0, check=False)
    sol = solve_ivp(
        rhs,
        (0.0, 50.0 * q_scale / v0),
        [0.0, v0],
        method="DOP853",
        rtol=RTOL_ODE,
        atol=[RTOL_ODE * q_scale, RTOL_ODE * v0],
        events=(touch, zero_force),
        dense_output=False,
    )
    tc, ec = float(sol.t_events[0][0]), -float(sol.y_events[0][0][1]) / v0
    if len(sol.t_events[1]):
        tz, ez = float(sol.t_events[1][0]), -float(sol.y_events[1][0][1]) / v0
    else:  # the force never pulls (hunt-crossley): the two ends coincide
        tz, ez = tc, ec
    return tc, ec, tz, ez, int(sol.nfev)


def _law_row(name, law, repeats):
    pot, m = hertz()
    v0 = LAW_V0
    t0 = time.perf_counter()
    sol = solve_law_impact(pot, m, v0, law)
    first = time.perf_counter() - t0
    truth = solve_law_impact_mp(pot, m, v0, law, dps=TRUTH_DPS)
    t_gen = _median_time(lambda: solve_law_impact(pot, m, v0, law), repeats, inner=5)
    tc, ec, tz, ez, nfev = _dop853_law(pot, m, v0, law)
    t_ode = _median_time(lambda: _dop853_law(pot, m, v0, law), max(3, repeats // 2))

    def rel(a, b):
        return abs(a / float(b) - 1)

    errs = {
        "contact_time": rel(sol.contact_time, truth["contact_time"]),
        "restitution": rel(sol.restitution, truth["restitution"]),
        "contact_time_zero_force": rel(
            sol.contact_time_zero_force, truth["contact_time_zero_force"]
        ),
        "restitution_zero_force": rel(sol.restitution_zero_force, truth["restitution_zero_force"]),
        "max_penetration": rel(sol.max_penetration, truth["max_penetration"]),
        "peak_force": rel(sol.peak_force, truth["peak_force"]),
    }
    row = {
        "law": name,
        "damping": law,
        "potential": repr(pot),
        "m": m,
        "v0": v0,
        "first_call_s": first,
        "exact_us": t_gen * 1e6,
        "exact_rel_errors": errs,
        "exact_max_rel_error": max(errs.values()),
        "exact_reported_bound_rel": sol.error_time / sol.contact_time,
        "dop853_us": t_ode * 1e6,
        "dop853_nfev": nfev,
        "dop853_contact_time_rel_error": rel(tc, truth["contact_time"]),
        "dop853_restitution_rel_error": rel(ec, truth["restitution"]),
        "dop853_zero_force_time_rel_error": rel(tz, truth["contact_time_zero_force"]),
        "speedup": t_ode / t_gen,
    }
    row["goal_met"] = bool(
        row["exact_us"] <= LAW_GOAL_US
        and row["speedup"] >= LAW_GOAL_SPEEDUP
        and row["exact_max_rel_error"] <= LAW_GOAL_ERROR
    )
    return row


def _batch_rows(repeats, dop_us):
    pot, m = PowerLaw(1.0e9, 1.5), 0.0041
    rng = np.random.default_rng(12345)
    v = 10.0 ** rng.uniform(-1.0, 1.0, BATCH_N)
    z = rng.uniform(0.0, BATCH_ZETA_MAX, BATCH_N)
    zg = np.repeat(np.linspace(0.0, BATCH_ZETA_MAX, GRID_ZETAS), GRID_SPEEDS)
    vg = np.tile(np.logspace(-1.0, 1.0, GRID_SPEEDS), GRID_ZETAS)
    rows = []
    for label, vs, zs in (
        (f"Hertz batch, {BATCH_N} distinct zeta in [0, {BATCH_ZETA_MAX}]", v, z),
        (f"Hertz batch, grid {GRID_ZETAS} zeta x {GRID_SPEEDS} v0", vg, zg),
    ):
        t0 = time.perf_counter()
        solve_impacts(pot, m, vs[:10], zs[:10])
        first = time.perf_counter() - t0
        dt = _median_time(lambda vs=vs, zs=zs: solve_impacts(pot, m, vs, zs), max(3, repeats // 2))
        out = solve_impacts(pot, m, vs, zs)
        # Spot check against the single-impact solver (same method, same round-off).
        idx = rng.integers(0, vs.size, 20)
        diff = max(
            abs(out["contact_time"][i] / solve_impact(pot, m, vs[i], zs[i]).contact_time - 1)
            for i in idx
        )
        per = dt / vs.size
        rows.append(
            {
                "workload": label,
                "first_call_s": first,
                "impacts_per_s": 1.0 / per,
                "us_per_impact": per * 1e6,
                "speedup_vs_dop853": dop_us / (per * 1e6),
                "max_rel_diff_vs_solve_impact": diff,
                "goal_met": bool(1.0 / per >= GOAL_BATCH),
            }
        )
    return rows


def run(repeats: int = 7) -> dict:
    rows = [_family_row(*scene, repeats) for scene in _scenes()]
    batch = _batch_rows(repeats, rows[0]["dop853_us"])
    laws = [
        _law_row(name, law, repeats)
        for name, law in calibrated_laws().items()
        if name != "universal"
    ]
    return {
        "families": rows,
        "batch": batch,
        "laws": laws,
        "law_goal": {
            "us_per_impact": LAW_GOAL_US,
            "speedup": LAW_GOAL_SPEEDUP,
            "error": LAW_GOAL_ERROR,
        },
        "law_truth": f"solve_law_impact_mp, {TRUTH_DPS} digits",
        "goal": {
            "us_per_impact": GOAL_US,
            "speedup": GOAL_SPEEDUP,
            "error": GOAL_ERROR,
            "batch_impacts_per_s": GOAL_BATCH,
        },
        "truth": f"solve_impact_mp, {TRUTH_DPS} digits",
        "dop853_rtol": RTOL_ODE,
        "load_average_1min": os.getloadavg()[0] if hasattr(os, "getloadavg") else None,
        "machine": machine_info(),
        "goal_met": all(r["goal_met"] for r in rows) and all(b["goal_met"] for b in batch),
        "law_goal_met": all(r["goal_met"] for r in laws),
    }


def _print(res: dict) -> None:
    print(f"exact solver vs DOP853 (rtol {RTOL_ODE:g}), zeta = {ZETA}, truth: {res['truth']}")
    head = (
        f"{'family':36s} {'exact us':>9s} {'err t_c':>8s} {'err e':>8s} {'DOP853 us':>10s}"
        f" {'err t_c':>8s} {'speed-up':>9s} {'1st call s':>10s} goal"
    )
    print(head)
    for r in res["families"]:
        print(
            f"{r['family']:36s} {r['exact_us']:9.1f} {r['exact_contact_time_rel_error']:8.1e}"
            f" {r['exact_restitution_rel_error']:8.1e} {r['dop853_us']:10.0f}"
            f" {r['dop853_contact_time_rel_error']:8.1e} {r['speedup']:8.0f}x"
            f" {r['first_call_s']:10.2f} {'met' if r['goal_met'] else 'NOT met'}"
        )
    for b in res["batch"]:
        print(
            f"{b['workload']:52s} {b['impacts_per_s']:10.3g} impacts/s"
            f" ({b['us_per_impact']:.2f} us, {b['speedup_vs_dop853']:.0f}x DOP853)"
            f" {'met' if b['goal_met'] else 'NOT met'}"
        )
    print("Hertz with each damping law (e = 0.8 at 1 m/s), general solver vs DOP853:")
    for r in res.get("laws", []):
        print(
            f"{r['law']:36s} {r['exact_us']:9.1f} {r['exact_max_rel_error']:8.1e}"
            f" {'':8s} {r['dop853_us']:10.0f} {r['dop853_contact_time_rel_error']:8.1e}"
            f" {r['speedup']:8.0f}x {r['first_call_s']:10.2f} {'met' if r['goal_met'] else 'NOT met'}"
        )
    mi = res["machine"]
    print(
        f"machine: {mi['platform']}, {mi['cpu_count']} cpus, load {res['load_average_1min']},"
        f" commit {mi['commit']}"
    )


def _laws_only(args) -> dict:
    """Law rows only, merged into the JSON file given (its other rows kept as measured)."""
    res = {}
    if args.json and os.path.exists(args.json):
        with open(args.json) as fh:
            res = json.load(fh)
    laws = [
        _law_row(name, law, args.repeats)
        for name, law in calibrated_laws().items()
        if name != "universal"
    ]
    res.update(
        {
            "laws": laws,
            "law_goal": {
                "us_per_impact": LAW_GOAL_US,
                "speedup": LAW_GOAL_SPEEDUP,
                "error": LAW_GOAL_ERROR,
            },
            "law_truth": f"solve_law_impact_mp, {TRUTH_DPS} digits",
            "law_goal_met": all(r["goal_met"] for r in laws),
            "laws_load_average_1min": os.getloadavg()[0] if hasattr(os, "getloadavg") else None,
            "laws_machine": machine_info(),
        }
    )
    res.setdefault("families", [])
    res.setdefault("batch", [])
    res.setdefault("truth", "?")
    res.setdefault("load_average_1min", None)
    res.setdefault("machine", machine_info())
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(res, fh, indent=2)
    return res


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", help="also write the result to this JSON file")
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument(
        "--laws-only",
        action="store_true",
        help="only the damping-law rows (merged into an existing --json file)",
    )
    args = ap.parse_args(argv)
    if args.laws_only:
        res = _laws_only(args)
        _print(res)
        return 0
    res = run(args.repeats)
    _print(res)
    if args.json:
        os.makedirs(os.path.dirname(os.path.abspath(args.json)), exist_ok=True)
        with open(args.json, "w") as fh:
            json.dump(res, fh, indent=2)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
