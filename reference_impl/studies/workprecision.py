"""Speed against error: work-precision data for the exact solver and ODE integrators.

Each method solves the same impact; its results are compared with a 30-digit
mpmath ground truth (`reference_impl.exact.solve.solve_impact_mp`, validated against
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

from reference_impl.errors import HCVInputError
from reference_impl.exact._truth import MpInverse
from reference_impl.exact.solve import solve_impact, solve_impact_mp
from reference_impl.integrators.ivp import integrate_impact
from reference_impl.integrators.verlet_path import verlet_impact
from reference_impl.potentials.base import Potential
from reference_impl.scenes import load_scene
from reference_impl.studies.paper import PAPER_MASS, paper_ellipsoid

__all__ = [
    "DEFAULT_METHODS",
    "FAMILY_ZETA",
    "METHODS",
    "Method",
    "QUICK_METHODS",
    "WPScene",
    "default_scenes",
    "family_scenes",
    "ground_truth",
    "remember_truth",
    "ivp_method",
    "resolve_method",
    "verlet_row",
    "work_precision",
]

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
# Damping ratio of the per-family scenes (universal law): a typical e ~ 0.5 impact.
FAMILY_ZETA = 0.2
# Solvers run on the added family scenes: the two explicit Runge-Kutta pairs only
# (Radau/LSODA and Verlet on them would cost minutes for no new information).
FAMILY_IVP_METHODS = ("DOP853", "RK45")


@dataclass(frozen=True)
class WPScene:
    """One impact of the study: potential, mass (kg), speed (m/s), damping ratio.

    ``ivp_methods`` restricts the solve_ivp methods run on it (None: the study's
    full list) and ``verlet`` says whether velocity Verlet points are added.
    """

    name: str
    potential: Potential
    m: float
    v0: float
    zeta: float
    ivp_methods: tuple[str, ...] | None = None
    verlet: bool = True


def family_scenes() -> list[WPScene]:
    """One damped impact (universal law, zeta = `FAMILY_ZETA`) per potential family.

    Hertz, the paper's ellipsoid, a sphere (R = 0.01 m, Kn = 1e8, alpha = 0.5,
    steel mass), a sum of two power laws and a user expression; shared with
    ``benchmarks/bench_exact.py``. Only DOP853 and RK45 are run on them. Every row is
    read from the one scene catalogue (``hcv scenes --show sphere-damped``), so the
    names in the README's speed table work in every command and mean the same scene.
    """

    z, fam = FAMILY_ZETA, FAMILY_IVP_METHODS

    def catalogue(name: str, v0: float) -> WPScene:
        sc = load_scene(name)
        if v0 not in sc.velocities or sc.zeta != z:
            raise AssertionError(f"scene {name}: v0 = {v0} or zeta = {z} not in the catalogue")
        return WPScene(name, sc.potential, sc.mass, v0, z, fam, False)

    return [
        catalogue("hertz-k1e9-damped", 1.0),
        catalogue("ellipsoid-damped", 0.99),
        catalogue("sphere-damped", 1.0),
        catalogue("power-sum-damped", 0.3),
        catalogue("expression-damped", 1.0),
    ]


# The family scenes already in the study's three original ones (by name).
_ORIGINAL = ("hertz-k1e9-damped",)


def default_scenes() -> list[WPScene]:
    """Hertz undamped and damped (e ~ 0.53), the paper's ellipsoid (v0 = 0.99), the
    damped sphere, sum of power laws and user expression of `family_scenes`, and the
    saturating force (catalogue scene ``saturating``, v0 = 1 m/s, undamped)."""

    # ~5 mm steel sphere on a wall, k = 4/3 E* sqrt(R) = 1e9 (catalogue: hertz-k1e9)
    hertz = load_scene("hertz-k1e9").potential
    added = [s for s in family_scenes() if s.name not in _ORIGINAL and s.name != "ellipsoid-damped"]
    # The saturating force's catalogue scene is undamped (the section 6 map's case); run
    # like the family scenes (DOP853 and RK45 only, no Verlet points).
    sat = load_scene("saturating")
    return [
        WPScene("hertz-k1e9", hertz, 0.0041, 1.0, 0.0),
        WPScene("hertz-k1e9-damped", hertz, 0.0041, 1.0, FAMILY_ZETA),
        WPScene("paper-ellipsoid", paper_ellipsoid(), PAPER_MASS, 0.99, 0.0),
        *added,
        WPScene("saturating", sat.potential, sat.mass, 1.0, 0.0, FAMILY_IVP_METHODS, False),
    ]


@dataclass(frozen=True)
class GroundTruth:
    contact_time: float
    restitution: float
    max_penetration: float
    t_samples: np.ndarray
    q_samples: np.ndarray


# Ground truths computed in this process, by scene (repr of potential, m, v0, zeta, dps).
_TRUTH_CACHE: dict[tuple, GroundTruth] = {}


def _truth_key(sc: WPScene, dps: int) -> tuple:
    """`_TRUTH_CACHE`'s key of a scene's truth at ``dps`` digits."""
    return (repr(sc.potential), sc.m, sc.v0, sc.zeta, dps)


def ground_truth(sc: WPScene, dps: int = _TRUTH_DPS) -> GroundTruth:
    """30-digit truth for scalars and for q at instants t(s_j), s_j nodes in virtual time.

    Cached per process by (potential repr, m, v0, zeta, dps). The trajectory part
    evaluates the potential's ``_U``, ``_dU`` with mpmath numbers (every family
    supports it) and ``_inverse`` on floats (seeds only).
    """
    key = _truth_key(sc, dps)
    if key in _TRUTH_CACHE:
        return _TRUTH_CACHE[key]

    ref = solve_impact_mp(sc.potential, sc.m, sc.v0, sc.zeta, dps=dps)
    pot, m = sc.potential, sc.m
    with mpmath.workdps(dps + 10):
        v0, z = mpmath.mpf(sc.v0), mpmath.mpf(sc.zeta)
        wd = mpmath.sqrt(1 - z * z)
        s_end = mpmath.pi / wd
        s_peak = mpmath.atan2(wd, z) / wd

        def x(s):
            return v0 / wd * mpmath.exp(-z * s) * mpmath.sin(wd * s)

        # seeded from a table up to the peak energy: one float inverse for all nodes
        inverse = MpInverse(pot, float(mpmath.mpf(m) * x(s_peak) ** 2 / 2))

        def q_of_x(xv):
            return inverse(mpmath.mpf(m) * xv * xv / 2)

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
    out = GroundTruth(
        float(ref["contact_time"]),
        float(ref["restitution"]),
        float(ref["max_penetration"]),
        np.array(ts),
        np.array(qs),
    )
    _TRUTH_CACHE[key] = out
    return out


def remember_truth(sc: WPScene, truth: GroundTruth, dps: int = _TRUTH_DPS) -> None:
    """Keep ``truth``, computed by `ground_truth` (sc, dps) in another process, as this
    process's: `ground_truth` then returns it instead of computing it again.

    `hcv report` computes the truths in its background processes beside the claims, so
    that its timed study (`work_precision`) finds them here; a truth is a deterministic
    function of the scene, so the rows are the same either way.
    """
    _TRUTH_CACHE[_truth_key(sc, dps)] = truth


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
    row = _row(
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
    # The solver's own bound on its contact-time error, made relative like err_contact_time.
    row["contact_time_bound"] = sol.quadrature_error / sol.contact_time
    return [row]


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


def _ivp_row(sc: WPScene, truth: GroundTruth, method, rtol: float) -> dict:
    """One solve_ivp point: ``method`` (a name or an OdeSolver subclass) at ``rtol``."""
    C = _damping(sc)
    name = method if isinstance(method, str) else method.__name__

    def run(dense=False):
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
        return {
            "scene": sc.name,
            "method": name,
            "setting": f"rtol={rtol:g}",
            "seconds": math.nan,
            "failure": str(exc).splitlines()[0],
        }
    return _row(
        sc, name, f"rtol={rtol:g}", secs, truth, res.contact_time, res.restitution, res.q_max, q
    )


@dataclass(frozen=True)
class Method:
    """A method of the study: its name, the settings it is run at, and how one point runs.

    ``run(scene, truth, setting) -> dict`` returns one row (`_row`'s fields, or
    ``failure``); ``settings`` are the full study's, ``quick_settings`` those of
    ``hcv report --quick``. ``applies(scene)`` says whether the scene asks for it.
    """

    name: str
    run: Callable[[WPScene, GroundTruth, object], dict]
    settings: tuple
    quick_settings: tuple
    applies: Callable[[WPScene], bool] = lambda sc: True


def ivp_method(method) -> Method:
    """A `Method` for a solve_ivp method: a name of `IVP_METHODS` or, as scipy accepts,
    a user's ``scipy.integrate.OdeSolver`` subclass (named by its class name)."""
    name = method if isinstance(method, str) else getattr(method, "__name__", repr(method))
    return Method(
        name,
        lambda sc, truth, rtol: _ivp_row(sc, truth, method, rtol),
        IVP_RTOLS,
        IVP_RTOLS[::2],
        lambda sc: sc.ivp_methods is None or name in sc.ivp_methods,
    )


def _verlet_method() -> Method:
    return Method(
        "Verlet",
        lambda sc, truth, n: verlet_row(sc, truth, n),
        VERLET_STEPS,
        VERLET_STEPS[::2],
        lambda sc: sc.verlet,
    )


# name -> Method: the study's registry (`resolve_method` also takes a Method or an
# OdeSolver subclass, so a user's integrator joins without an edit here).
METHODS: dict[str, Method] = {m: ivp_method(m) for m in IVP_METHODS}
METHODS["Verlet"] = _verlet_method()
# What ``hcv report`` runs (quick: the two explicit Runge-Kutta pairs and Verlet).
DEFAULT_METHODS = (*IVP_METHODS, "Verlet")
QUICK_METHODS = ("DOP853", "RK45", "Verlet")


def resolve_method(method) -> Method:
    """A `Method` from a registered name, a `Method`, or an OdeSolver subclass."""
    from scipy.integrate import OdeSolver

    if isinstance(method, Method):
        return method
    if isinstance(method, str):
        if method not in METHODS:
            raise HCVInputError(
                f"work_precision: unknown method {method!r}; known: {', '.join(METHODS)}, "
                "or pass a scipy.integrate.OdeSolver subclass or a Method"
            )
        return METHODS[method]
    if isinstance(method, type) and issubclass(method, OdeSolver):
        return ivp_method(method)
    raise HCVInputError(
        f"work_precision: a method must be a name, a Method or an OdeSolver subclass, got {method!r}"
    )


def work_precision(
    scenes=None,
    *,
    quick: bool = False,
    methods=None,
    progress: Callable[[str], None] | None = None,
) -> pd.DataFrame:
    """Run the study and return one row per (scene, method, setting).

    Parameters
    ----------
    scenes : list of WPScene, optional
        Defaults to `default_scenes`.
    quick : bool
        Fewer tolerances and methods (for ``hcv report --quick``).
    methods : sequence, optional
        Names in `METHODS`, `Method` objects, or ``scipy.integrate.OdeSolver``
        subclasses; None runs `DEFAULT_METHODS` (`QUICK_METHODS` when quick). The
        exact solver is always the first row of each scene.
    progress : callable, optional
        Called with a short description before each scene.
    """
    scenes = default_scenes() if scenes is None else scenes
    if methods is None:
        methods = QUICK_METHODS if quick else DEFAULT_METHODS
    resolved = [resolve_method(m) for m in methods]
    rows: list[dict] = []
    for sc in scenes:
        if progress:
            progress(f"work-precision: {sc.name}")
        truth = ground_truth(sc)
        rows += _exact_rows(sc, truth)
        for meth in resolved:
            if not meth.applies(sc):
                continue
            for setting in meth.quick_settings if quick else meth.settings:
                rows.append(meth.run(sc, truth, setting))
    return pd.DataFrame(rows)


# Step budget of one run, in multiples of the requested steps per contact, plus a
# constant: damping lengthens the contact by at most ~2.3 (zeta <= 0.9).
_BUDGET_FACTOR = 4
_BUDGET_EXTRA = 64


def verlet_row(sc, truth, steps_per_contact: int) -> dict:
    """Work-precision row of velocity Verlet with dt = t_contact / steps_per_contact.

    The callback `reference_impl.studies.workprecision.work_precision` expects: errors
    against the mpmath ``truth`` and the median wall time of a whole impact.
    """
    dt = truth.contact_time / steps_per_contact
    budget = _BUDGET_FACTOR * steps_per_contact + _BUDGET_EXTRA
    path = verlet_impact(sc.potential, sc.m, sc.v0, sc.zeta, dt, budget)
    secs = _median_time(lambda: verlet_impact(sc.potential, sc.m, sc.v0, sc.zeta, dt, budget))
    q = path.q(truth.t_samples)
    err_traj = float(np.max(np.abs(q - truth.q_samples))) / truth.max_penetration
    return {
        "scene": sc.name,
        "method": "Verlet",
        "setting": f"{steps_per_contact} steps/contact",
        "seconds": secs,
        "err_contact_time": _rel(path.contact_time, truth.contact_time),
        "err_restitution": _rel(path.restitution, truth.restitution),
        "err_max_penetration": _rel(path.max_penetration, truth.max_penetration),
        "err_trajectory": err_traj if math.isfinite(err_traj) else math.nan,
        "dt": dt,
    }
