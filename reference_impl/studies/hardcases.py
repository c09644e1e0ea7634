"""Hard cases: what each part of the suite does at the edges, and where accuracy is lost.

Parts run on every case: the section 6 bound (`stability.dt_safe`, geometry
class, the endpoint shortcut), the measured critical step of a single impact
(`dtcrit.search_scene`), the exact solver (`solve_impact`) against a 25-digit
mpmath reference (the physical-integral contact duration for conservative
contacts, `solve_impact_mp` for damped ones), scipy DOP853 at rtol 1e-12
(`integrate_impact`) against the same reference, and velocity Verlet at 1000
steps per contact. A part that refuses a case reports its one-line error.

Computation only: the report draws the sweeps (`reference_impl.report._hardcases`) from
the rows and `SETTINGS` written to results.json.
"""

from __future__ import annotations

import math
import time

import numpy as np

from reference_impl._format import g
from reference_impl.errors import HCVInputError
from reference_impl.exact.solve import solve_impact, solve_impact_mp
from reference_impl.integrators.ivp import integrate_impact
from reference_impl.integrators.verlet_path import verlet_impact
from reference_impl.potentials import Ellipsoid, PowerLaw
from reference_impl.stability.bound import dt_safe
from reference_impl.stability.search import search_scene
from reference_impl.studies.paper import PAPER_MASS, paper_ellipsoid
from reference_impl.theory import action as act

_MP_DPS = 25
_ODE_RTOL = 1e-12
_VERLET_STEPS = 1000
# Hertz-like steel sphere of radius ~5 mm (as in the work-precision scenes).
_HERTZ_M = 0.0041
# Errors above these count as "accuracy lost" in the summary (exact solver: its
# goal of 1e-13; DOP853 at rtol 1e-12: 1e-10, two decades of global accumulation).
_EXACT_LOST = 1e-13
_ODE_LOST = 1e-10

__all__ = [
    "SETTINGS",
    "case_labels",
    "lost_accuracy",
    "measure_case",
    "run_hard_cases",
    "run_sweeps",
]

# What the study ran, for the figure's legend (written to results.json).
SETTINGS = {"ode_rtol": _ODE_RTOL, "verlet_steps": _VERLET_STEPS, "mp_dps": _MP_DPS}


def _v_for_depth(pot: Ellipsoid, m: float, frac: float) -> float:
    """Impact speed whose turning point is frac * a."""
    return math.sqrt(2.0 * float(pot.U(frac * pot.a)) / m)


def _cases(quick: bool):
    ell = paper_ellipsoid()
    m = PAPER_MASS
    cases = [
        ("Hertz, very stiff k = 1e12", PowerLaw(1e12, 1.5), _HERTZ_M, 1.0, 0.0),
        ("Hertz, very soft k = 1", PowerLaw(1.0, 1.5), _HERTZ_M, 1.0, 0.0),
        ("Hertz k = 1e9, v0 = 1e-6 m/s", PowerLaw(1e9, 1.5), _HERTZ_M, 1e-6, 0.0),
        ("Hertz k = 1e9, v0 = 1e3 m/s", PowerLaw(1e9, 1.5), _HERTZ_M, 1e3, 0.0),
        (
            "ellipsoid, very stiff Kn = 1e12",
            Ellipsoid(0.015, 0.008, 0.008, 1e12, 0.5),
            m,
            0.99,
            0.0,
        ),
        ("ellipsoid, very soft Kn = 1e6", Ellipsoid(0.015, 0.008, 0.008, 1e6, 0.5), m, 0.99, 0.0),
        ("softening p = 0.5 (k = 1e3)", PowerLaw(1e3, 0.5), m, 1.0, 0.0),
        ("softening p = 0.5, ζ = 0.3", PowerLaw(1e3, 0.5), m, 1.0, 0.3),
        ("ellipsoid q_max = 0.8 a", ell, m, _v_for_depth(ell, m, 0.8), 0.0),
        ("ellipsoid q_max = 1.5 a", ell, m, _v_for_depth(ell, m, 1.5), 0.0),
        ("ellipsoid q_max = 1.99 a", ell, m, _v_for_depth(ell, m, 1.99), 0.0),
        ("ellipsoid q_max = 1.9999 a", ell, m, _v_for_depth(ell, m, 1.9999), 0.0),
    ]
    if quick:
        keep = {0, 2, 3, 5, 6, 9, 11}
        cases = [c for i, c in enumerate(cases) if i in keep]
    return cases


def case_labels(quick: bool) -> list[str]:
    """The labels of the cases the study runs (full or quick)."""
    return [c[0] for c in _cases(quick)]


def _err(e: Exception) -> str:
    return f"{type(e).__name__}: {str(e).splitlines()[0]}"


def _reference(pot, m, v0, zeta):
    if zeta == 0:
        return float(act.contact_duration_mp(pot, m, 0.5 * m * v0 * v0, dps=_MP_DPS))
    return float(solve_impact_mp(pot, m, v0, zeta, dps=_MP_DPS)["contact_time"])


def _universal_C(pot, m, zeta):
    if zeta == 0:
        return None

    def C(q):
        q = np.asarray(q, dtype=float)
        with np.errstate(divide="ignore", invalid="ignore"):
            c = 2 * zeta * math.sqrt(m) * pot._dU(q) / np.sqrt(2 * pot._U(q))
        return np.where(q > 0, c, 0.0)

    return C


def _rel(a, b):
    return abs(a / b - 1.0) if (math.isfinite(a) and math.isfinite(b) and b) else math.nan


def measure_case(label, pot, m, v0, zeta, *, search: bool = True) -> dict:
    """Every part of the suite on one impact; failures are recorded, not raised."""
    row = {"case": label, "potential": repr(pot), "m": m, "v0": v0, "zeta": zeta, "notes": []}
    a = getattr(pot, "a", None)
    try:
        q_max = pot.turning_point(0.5 * m * v0 * v0)
        row["q_max"] = q_max
        row["q_max_over_a"] = q_max / a if a else math.nan
    except HCVInputError as e:
        row["q_max"] = math.nan
        row["notes"].append(f"every part refuses the case: {_err(e)}")
        return row
    try:
        s = dt_safe(pot, m, v0)
        row.update(
            dt_safe=s.dt_safe,
            geometry=s.geometry,
            shortcut_over_safe=s.dt_shortcut / s.dt_safe if s.dt_safe > 0 else math.inf,
        )
    except HCVInputError as e:
        row["notes"].append(f"dt_safe: {_err(e)}")
    if search:
        try:
            r = search_scene(pot, m, [v0], "impact", zeta=zeta)[0]
            row["dtcrit_over_safe"] = r.ratio
            row["dtcrit_over_rec"] = r.dt_crit / r.recommended_dt
        except HCVInputError as e:
            row["notes"].append(f"search_scene: {_err(e)}")
    try:
        ref = _reference(pot, m, v0, zeta)
        row["t_c_ref"] = ref
    except (HCVInputError, ArithmeticError, ZeroDivisionError) as e:
        ref = math.nan
        row["notes"].append(f"mpmath reference: {_err(e)}")
    try:
        t0 = time.perf_counter()
        sol = solve_impact(pot, m, v0, zeta)
        row["exact_seconds"] = time.perf_counter() - t0
        row["exact_err_t_c"] = _rel(sol.contact_time, ref)
        row["exact_quadrature_estimate"] = sol.quadrature_error / sol.contact_time
    except HCVInputError as e:
        row["notes"].append(f"solve_impact: {_err(e)}")
    try:
        run = integrate_impact(pot, m, v0, C=_universal_C(pot, m, zeta), rtol=_ODE_RTOL)
        row["ode_err_t_c"] = _rel(run.contact_time, ref)
        row["ode_nfev"] = run.nfev
    except (HCVInputError, RuntimeError) as e:
        row["notes"].append(f"integrate_impact: {_err(e)}")
    if math.isfinite(ref):
        n = _VERLET_STEPS
        path = verlet_impact(pot, m, v0, zeta, ref / n, 4 * n + 64)
        row["verlet_err_t_c"] = _rel(path.contact_time, ref)
        if path.blown:
            row["notes"].append(f"Verlet at {n} steps/contact left the domain (q > q_sup)")
    return row


def run_hard_cases(quick: bool, progress=None) -> list[dict]:
    rows = []
    for label, pot, m, v0, zeta in _cases(quick):
        if progress:
            progress(f"hard cases: {label}")
        rows.append(measure_case(label, pot, m, v0, zeta))
    return rows


def run_sweeps(quick: bool, progress=None) -> dict:
    """Errors across speeds (Hertz) and across depths q_max/a (ellipsoid)."""
    if progress:
        progress("hard cases: sweeps")
    n = 5 if quick else 10
    hertz = PowerLaw(1e9, 1.5)
    speed = [
        measure_case(f"v0={v:.3g}", hertz, _HERTZ_M, float(v), 0.0, search=False)
        for v in np.logspace(-6, 3, n)
    ]
    ell = paper_ellipsoid()
    fracs = (
        [0.05, 0.447, 0.9, 1.5, 1.999]
        if quick
        else [0.01, 0.05, 0.2, 0.447, 0.7, 0.8, 1.0, 1.3, 1.6, 1.9, 1.99, 1.999, 1.9999]
    )
    depth = [
        measure_case(f"q_max={f:g}a", ell, PAPER_MASS, _v_for_depth(ell, PAPER_MASS, f), 0.0)
        for f in fracs
    ]
    return {"speed": speed, "depth": depth}


def lost_accuracy(rows: list[dict], sweep_rows: list[dict] = ()) -> list[str]:
    """Measured statements of where accuracy is lost.

    ``rows`` are the hard cases; ``sweep_rows`` (the speed and depth sweeps) add
    only their solver-accuracy findings.
    """
    out = []

    def key(r):
        return r.get("potential"), r["m"], r["v0"], r["zeta"]

    seen = {key(r) for r in rows}
    sweep_rows = [dict(r, case=f"sweep {r['case']}") for r in sweep_rows if key(r) not in seen]
    every = list(rows) + sweep_rows
    ok_exact = [r for r in every if r.get("exact_err_t_c", math.inf) <= _EXACT_LOST]
    if ok_exact:
        worst = max(r["exact_err_t_c"] for r in ok_exact)
        out.append(
            f"exact solver within {g(_EXACT_LOST)} of the 25-digit contact time on "
            f"{len(ok_exact)} of {len(every)} cases and sweep points (worst {g(worst, 2)})"
        )
    for r in every:
        if r.get("exact_err_t_c", 0) > _EXACT_LOST:
            out.append(
                f"exact solver loses accuracy: {r['case']}: t_c error "
                f"{g(r['exact_err_t_c'], 2)} (its own estimate "
                f"{g(r.get('exact_quadrature_estimate'), 2)})"
            )
    for r in every:
        if r.get("ode_err_t_c", 0) > _ODE_LOST:
            out.append(
                f"DOP853 rtol {g(_ODE_RTOL)} loses accuracy: {r['case']}: t_c error "
                f"{g(r['ode_err_t_c'], 2)} ({r.get('ode_nfev')} evaluations)"
            )
    for r in rows:
        if r.get("dt_safe") == 0:
            out.append(
                f"Δt_safe = 0 (degenerate bound): {r['case']}"
                + (
                    f"; measured Δt_crit is finite, recommended step margin "
                    f"Δt_crit/Δt_rec = {r['dtcrit_over_rec']:.2f}"
                    if "dtcrit_over_rec" in r
                    else ""
                )
            )
    for r in rows:
        if r.get("geometry") == "mixed" and r.get("shortcut_over_safe", 1) > 1 + 1e-9:
            out.append(
                f"beyond the stiffening domain: {r['case']}: the shortcut 2 m v0/U'(q_max) "
                f"is {r['shortcut_over_safe']:.4g} × Δt_safe (not a bound); measured "
                f"Δt_crit/Δt_safe = {g(r.get('dtcrit_over_safe'))}"
            )
    for r in every:
        if r.get("dtcrit_over_rec", math.inf) <= 1:
            out.append(
                f"the recommended step fails: {r['case']}: Δt_crit/Δt_rec = "
                f"{r['dtcrit_over_rec']:.3g}"
            )
    for r in rows:
        if math.isnan(r.get("q_max", math.nan)):
            out.append(f"{r['case']}: {'; '.join(r['notes'])}")
    return out
