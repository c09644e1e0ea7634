"""Speed against error: work-precision data for the exact solver and ODE integrators.

Each method solves the same impact; its results are compared with a 30-digit
mpmath ground truth (`reference_impl.impact.solve_impact_mp`, validated against
the Taylor ODE solver and direct physical quadratures in the suite) and its
wall time is the median of repeats in the same process. Errors reported:

* contact time, restitution and maximum penetration (relative);
* the trajectory q(t): max |q - q_true| / q_max over sample instants, whose
  truth is computed at nodes of virtual time s (t(s) by one quadrature each).
"""

from __future__ import annotations

import math
import statistics
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass

import mpmath
import numpy as np
import pandas as pd

from .impact import solve_impact
from .integrators.ivp import integrate_impact
from .paper import PAPER_MASS, paper_ellipsoid
from .potentials import PowerLaw
from .potentials.base import Potential

__all__ = ["WPScene", "default_scenes", "ground_truth", "work_precision"]

# Number of trajectory sample instants (virtual-time nodes spread over the contact).
_TRAJ_SAMPLES = 12
# Digits of the ground truth: far below any method's error (the exact solver's is ~1e-15).
_TRUTH_DPS = 30
# A timing repeats the call until this much wall time has accumulated (s), at
# least _MIN_REPEATS times, and reports the median per call.
_TIME_BUDGET = 0.05
_MIN_REPEATS = 3
# solve_ivp tolerances swept (rtol); atol scales with it inside integrate_impact.
IVP_RTOLS = (1e-3, 1e-5, 1e-7, 1e-9, 1e-11, 1e-13)
IVP_METHODS = ("RK45", "DOP853", "Radau", "LSODA")
# Verlet steps per contact swept.
VERLET_STEPS = (10, 30, 100, 300, 1000, 3000, 10000)


@dataclass(frozen=True)
class WPScene:
    """One impact of the study: potential, mass (kg), speed (m/s), damping ratio."""

    name: str
    potential: Potential
    m: float
    v0: float
    zeta: float


def default_scenes() -> list[WPScene]:
    """A Hertz impact, the same damped to e ~ 0.53, and the paper's ellipsoid (v0 = 0.99)."""
    hertz = PowerLaw(1.0e9, 1.5)  # ~5 mm steel sphere on a wall, k = 4/3 E* sqrt(R)
    return [
        WPScene("hertz", hertz, 0.0041, 1.0, 0.0),
        WPScene("hertz-damped", hertz, 0.0041, 1.0, 0.2),
        WPScene("paper-ellipsoid", paper_ellipsoid(), PAPER_MASS, 0.99, 0.0),
    ]


@dataclass(frozen=True)
class GroundTruth:
    contact_time: float
    restitution: float
    max_penetration: float
    t_samples: np.ndarray
    q_samples: np.ndarray


def ground_truth(sc: WPScene, dps: int = _TRUTH_DPS) -> GroundTruth:
    """30-digit truth for scalars and for q at instants t(s_j), s_j nodes in virtual time."""
    from .impact import solve_impact_mp

    ref = solve_impact_mp(sc.potential, sc.m, sc.v0, sc.zeta, dps=dps)
    pot, m = sc.potential, sc.m
    with mpmath.workdps(dps + 10):
        v0, z = mpmath.mpf(sc.v0), mpmath.mpf(sc.zeta)
        wd = mpmath.sqrt(1 - z * z)
        s_end = mpmath.pi / wd
        s_peak = mpmath.atan2(wd, z) / wd

        def x(s):
            return v0 / wd * mpmath.exp(-z * s) * mpmath.sin(wd * s)

        def q_of_x(xv):
            u = mpmath.mpf(m) * xv * xv / 2
            q0 = mpmath.mpf(float(pot._inverse(np.array([float(u)]))[0]))
            return mpmath.findroot(
                lambda q: pot._U(q) - u, (q0 * (1 - 1e-9), q0 * (1 + 1e-9)), solver="anderson"
            )

        def g(s):
            xv = x(s)
            return mpmath.mpf(m) * xv / pot._dU(q_of_x(xv)) if xv > 0 else mpmath.mpf(0)

        ts, qs = [], []
        # Interior nodes only: q = 0 at the ends is trivially matched by every method.
        for j in range(1, _TRAJ_SAMPLES + 1):
            s = s_end * j / (_TRAJ_SAMPLES + 1)
            pts = [0, s] if s <= s_peak else [0, s_peak, s]
            ts.append(float(mpmath.quad(g, pts)))
            qs.append(float(q_of_x(x(s))))
    return GroundTruth(
        float(ref["contact_time"]),
        float(ref["restitution"]),
        float(ref["max_penetration"]),
        np.array(ts),
        np.array(qs),
    )


def _median_time(fn: Callable[[], object]) -> float:
    times: list[float] = []
    spent = 0.0
    while len(times) < _MIN_REPEATS or spent < _TIME_BUDGET:
        t0 = time.perf_counter()
        fn()
        dt = time.perf_counter() - t0
        times.append(dt)
        spent += dt
        if len(times) >= 200:
            break
    return statistics.median(times)


def _rel(a: float, b: float) -> float:
    if not (math.isfinite(a) and math.isfinite(b)):
        return math.inf
    return abs(a - b) / abs(b) if b != 0 else abs(a - b)


def _row(sc, method, setting, seconds, truth, tc, e, qm, q_traj) -> dict:
    err_traj = float(np.max(np.abs(np.asarray(q_traj) - truth.q_samples))) / truth.max_penetration
    return {
        "scene": sc.name,
        "method": method,
        "setting": setting,
        "seconds": seconds,
        "err_contact_time": _rel(tc, truth.contact_time),
        "err_restitution": _rel(e, truth.restitution),
        "err_max_penetration": _rel(qm, truth.max_penetration),
        "err_trajectory": err_traj,
    }


def _exact_rows(sc: WPScene, truth: GroundTruth) -> list[dict]:
    sol = solve_impact(sc.potential, sc.m, sc.v0, sc.zeta)
    q, _ = sol.state(truth.t_samples)
    secs = _median_time(lambda: solve_impact(sc.potential, sc.m, sc.v0, sc.zeta))
    return [
        _row(
            sc,
            "exact",
            "harmonic map",
            secs,
            truth,
            sol.contact_time,
            sol.restitution,
            sol.max_penetration,
            q,
        )
    ]


def _damping(sc: WPScene):
    if sc.zeta == 0:
        return None
    pot, m, z = sc.potential, sc.m, sc.zeta

    def C(q):
        # Universal law with K = M = m: C = 2 zeta sqrt(m) U' / sqrt(2U).
        q = np.asarray(q, dtype=float)
        with np.errstate(divide="ignore", invalid="ignore"):
            c = 2 * z * math.sqrt(m) * pot._dU(q) / np.sqrt(2 * pot._U(q))
        return np.where(q > 0, c, 0.0)

    return C


def _ivp_rows(sc: WPScene, truth: GroundTruth, methods, rtols) -> list[dict]:
    rows = []
    C = _damping(sc)
    for method in methods:
        for rtol in rtols:

            def run(method=method, rtol=rtol, dense=False):
                return integrate_impact(
                    sc.potential, sc.m, sc.v0, C=C, method=method, rtol=rtol, dense_output=dense
                )

            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    res = run(dense=True)
                    q = np.asarray(res.sol(truth.t_samples))[0] if res.sol is not None else np.nan
                    secs = _median_time(run)
            except Exception as exc:  # a method that fails at this tolerance is a data point
                rows.append(
                    {
                        "scene": sc.name,
                        "method": method,
                        "setting": f"rtol={rtol:g}",
                        "seconds": math.nan,
                        "failure": str(exc).splitlines()[0],
                    }
                )
                continue
            rows.append(
                _row(
                    sc,
                    method,
                    f"rtol={rtol:g}",
                    secs,
                    truth,
                    res.contact_time,
                    res.restitution,
                    res.q_max,
                    q,
                )
            )
    return rows


def work_precision(
    scenes=None,
    *,
    quick: bool = False,
    verlet: Callable | None = None,
    progress: Callable[[str], None] | None = None,
) -> pd.DataFrame:
    """Run the study and return one row per (scene, method, setting).

    Parameters
    ----------
    scenes : list of WPScene, optional
        Defaults to `default_scenes`.
    quick : bool
        Fewer tolerances and methods (for ``hcv report --quick``).
    verlet : callable, optional
        ``verlet(scene, truth, steps_per_contact) -> row dict`` adding velocity
        Verlet points (provided by the report, which owns the Verlet engine).
    progress : callable, optional
        Called with a short description before each scene.
    """
    scenes = default_scenes() if scenes is None else scenes
    methods = ("DOP853", "RK45") if quick else IVP_METHODS
    rtols = IVP_RTOLS[::2] if quick else IVP_RTOLS
    steps = VERLET_STEPS[::2] if quick else VERLET_STEPS
    rows: list[dict] = []
    for sc in scenes:
        if progress:
            progress(f"work-precision: {sc.name}")
        truth = ground_truth(sc)
        rows += _exact_rows(sc, truth)
        rows += _ivp_rows(sc, truth, methods, rtols)
        if verlet is not None:
            for n in steps:
                rows.append(verlet(sc, truth, n))
    return pd.DataFrame(rows)
