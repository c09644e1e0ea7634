"""Exact harmonic-map solver against scipy DOP853 on one damped Hertz impact.

Both are timed in the same process (median of repeats) and scored against
the mpmath ground truth (`solve_impact_mp`, 30 digits). Goal of the project:
the exact solver >= 300 times faster than DOP853 at rtol 1e-12, with a relative
error <= 1e-13.

Run: ``python -m benchmarks.bench_exact [--json FILE]``.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import time

from scipy.integrate import solve_ivp

from reference_impl.impact import solve_impact, solve_impact_mp
from reference_impl.potentials import PowerLaw

from ._machine import machine_info

# The scene: a 1 cm steel-like Hertz contact (k ~ 4/3 E* sqrt(R)), damped to e ~ 0.5.
K_HERTZ = 1.0e9  # N / m^1.5
P_HERTZ = 1.5
MASS = 0.0041  # kg, steel sphere of radius 5 mm
V0 = 1.0  # m/s
ZETA = 0.2
RTOL_ODE = 1e-12
GOAL_SPEEDUP = 300.0
GOAL_ERROR = 1e-13


def _median_time(fn, repeats: int, inner: int = 1) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(inner):
            fn()
        times.append((time.perf_counter() - t0) / inner)
    return statistics.median(times)


def _dop853():
    """DOP853 with a lean scalar right-hand side (the fastest fair use of solve_ivp)."""
    k, p, m, z = K_HERTZ, P_HERTZ, MASS, ZETA
    # Universal law for a power law: C(q) = 2 zeta sqrt(m k (p+1)/2) q^((p-1)/2).
    c = 2.0 * z * math.sqrt(m * k * (p + 1.0) / 2.0)
    e = (p - 1.0) / 2.0

    def rhs(t, y):
        q, v = y
        if q <= 0.0:
            return [v, 0.0]
        return [v, -(k * q**p + c * q**e * v) / m]

    def touch(t, y):
        return y[0]

    touch.terminal, touch.direction = True, -1
    q_scale = ((p + 1) * 0.5 * m * V0**2 / k) ** (1 / (p + 1))
    sol = solve_ivp(
        rhs,
        (0.0, 1.0),
        [0.0, V0],
        method="DOP853",
        rtol=RTOL_ODE,
        atol=[RTOL_ODE * q_scale, RTOL_ODE * V0],
        events=touch,
    )
    tc = float(sol.t_events[0][0])
    return tc, -float(sol.y_events[0][0][1]) / V0, sol.nfev


def run(repeats: int = 7) -> dict:
    pot = PowerLaw(K_HERTZ, P_HERTZ)
    truth = solve_impact_mp(pot, MASS, V0, ZETA, dps=30)
    t_true, e_true = float(truth["contact_time"]), float(truth["restitution"])
    sol = solve_impact(pot, MASS, V0, ZETA)
    t_exact = _median_time(lambda: solve_impact(pot, MASS, V0, ZETA), repeats, inner=20)
    tc, e, nfev = _dop853()
    t_ode = _median_time(_dop853, repeats)
    res = {
        "scene": {"k": K_HERTZ, "p": P_HERTZ, "m": MASS, "v0": V0, "zeta": ZETA},
        "exact": {
            "seconds": t_exact,
            "contact_time_rel_error": abs(sol.contact_time / t_true - 1),
            "restitution_rel_error": abs(sol.restitution / e_true - 1),
        },
        "dop853": {
            "rtol": RTOL_ODE,
            "seconds": t_ode,
            "nfev": nfev,
            "contact_time_rel_error": abs(tc / t_true - 1),
            "restitution_rel_error": abs(e / e_true - 1),
        },
        "speedup": t_ode / t_exact,
        "goal": {"speedup": GOAL_SPEEDUP, "error": GOAL_ERROR},
        "machine": machine_info(),
    }
    res["goal_met"] = bool(
        res["speedup"] >= GOAL_SPEEDUP
        and res["exact"]["contact_time_rel_error"] <= GOAL_ERROR
        and res["exact"]["restitution_rel_error"] <= GOAL_ERROR
    )
    return res


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", help="also write the result to this JSON file")
    ap.add_argument("--repeats", type=int, default=7)
    args = ap.parse_args(argv)
    res = run(args.repeats)
    ex, od = res["exact"], res["dop853"]
    print(f"damped Hertz impact (zeta={ZETA}), truth: mpmath 30 digits")
    print(
        f"  exact solver : {ex['seconds'] * 1e6:9.1f} us   rel err t_c {ex['contact_time_rel_error']:.2e}"
        f"  e {ex['restitution_rel_error']:.2e}"
    )
    print(
        f"  DOP853 {RTOL_ODE:g}: {od['seconds'] * 1e6:9.1f} us   rel err t_c {od['contact_time_rel_error']:.2e}"
        f"  e {od['restitution_rel_error']:.2e}  ({od['nfev']} f-evals)"
    )
    print(
        f"  speed-up     : {res['speedup']:.0f}x  (goal >= {GOAL_SPEEDUP:.0f}x at <= {GOAL_ERROR:g}):"
        f" {'met' if res['goal_met'] else 'NOT met'}"
    )
    print(
        f"  machine      : {res['machine']['platform']}, {res['machine']['cpu_count']} cpus, "
        f"commit {res['machine']['commit']}"
    )
    if args.json:
        import os

        os.makedirs(os.path.dirname(os.path.abspath(args.json)), exist_ok=True)
        with open(args.json, "w") as fh:
            json.dump(res, fh, indent=2)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
