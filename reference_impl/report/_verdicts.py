"""Measured verdicts of the theory claims (sections 4, 5, 7, 8, 9, 10 and Table 1).

Each function runs a small, fast measurement with the library, applies a rule
stated in its docstring to the measured numbers and returns
``{"verdict", "evidence", "rule", "measured"}``. Nothing is typed in except
the paper's own data (`reference_impl.paper`) and the tolerances of the rules.
The figures (Fig. 1), the critical-step map (section 6) and the hard cases
live in their own modules.
"""

from __future__ import annotations

import math

import mpmath
import numpy as np

from .. import action as act
from ..damping import UniversalDamping, restitution_from_zeta, tsuji_coefficient
from ..harmonic_map import HarmonicMap
from ..impact import solve_impact
from ..integrators.ivp import integrate_impact
from ..paper import (
    PAPER_MASS,
    STIFFENING_LIMIT_PRINTED,
    TABLE1_PRINTED,
    paper_ellipsoid,
    table1_cells,
)
from ..potentials import PowerLaw
from ..stability import stiffening_indicator
from ._common import g

# -- tolerances of the rules ---------------------------------------------------------
# Theorem 1 at 40 digits: a relation that holds agrees to ~1e-45 (10 guard digits).
_THM1_DPS = 40
_THM1_TOL = mpmath.mpf("1e-20")
# Tight DOP853 runs: global error ~1e-10 over one contact (see the suite's tests).
_ODE_RTOL = 1e-12
# x(tau) against the sinusoid, relative to its amplitude: integrator-limited.
_SINUSOID_TOL = 1e-8
# Spreads of quantities that cancel analytically are round-off (~1e-16); "measurable"
# differences are far above the ODE error (1e-8 for two runs).
_ROUNDOFF_TOL = 1e-13
_MEASURABLE = 1e-5
# Restitution spread under the universal law: the ODE error bound 1e-9 + 1e-8 e.
_E_TOL = 1e-8
# Factor by which a perturbed law's spread must exceed the universal one.
_ORDERS = 1e3
# Exact solver against the 30-digit physical quadrature of the contact time.
_EXACT_RTOL = 1e-13
# Log-log slopes of exact power functions (least squares over six decades).
_SLOPE_TOL = 1e-10

# Cases shared by several claims.
_HERTZ = PowerLaw(1e6, 1.5)
_MASS = 0.05
_KM_PAIRS = ((1.0, 1.0), (1.0, 0.75), (1e-3, 1e3), (250.0, 4e-3), (37.0, 0.02))
# Random (K, M) draws of the Theorem 2 check: fixed seed, recorded in results.json.
SEED_KM = 20260401


def _cases():
    """(label, potential, mass kg, impact speed m/s): Hertz, the paper ellipsoid, a sum."""
    return [
        ("Hertz k=1e6 p=1.5", _HERTZ, _MASS, 1.0),
        ("paper ellipsoid", paper_ellipsoid(), PAPER_MASS, 0.99),
        ("sum q^2/2 + q^3/3 (k=1e4, 1e6)", PowerLaw(1e4, 1.0) + PowerLaw(1e6, 2.0), _MASS, 1.0),
    ]


def _result(verdict: str, evidence: str, rule: str, measured: dict) -> dict:
    return {"verdict": verdict, "evidence": evidence, "rule": rule, "measured": measured}


# ==================================================================================
# Theorem 1
# ==================================================================================
def thm1_period() -> dict:
    """T / (2 pi dJ/dE) at 40 digits, dJ/dE by mpmath.diff of J; refuted if |ratio - 1| > 1e-20."""
    cases = {
        "Hertz": (_HERTZ, _MASS, 0.0123),
        "paper ellipsoid": (paper_ellipsoid(), PAPER_MASS, 0.5 * PAPER_MASS * 0.99**2),
    }
    rows = {}
    with mpmath.workdps(_THM1_DPS + 10):
        for name, (pot, m, E) in cases.items():
            T = act.period_mp(pot, m, E, dps=_THM1_DPS)
            tc = act.contact_duration_mp(pot, m, E, dps=_THM1_DPS)
            dJ = act.dJ_dE_mp(pot, m, E, dps=_THM1_DPS)
            ratio = T / (2 * mpmath.pi * dJ)
            rows[name] = {
                "E_J": E,
                "T_s": mpmath.nstr(T, 25),
                "dJ_dE_s": mpmath.nstr(dJ, 25),
                "T_over_2pi_dJdE": mpmath.nstr(ratio, 30, strip_zeros=False),
                "abs_ratio_minus_1": float(abs(ratio - 1)),
                "abs_ratio_minus_2": float(abs(ratio - 2)),
                "abs_tc_over_2pi_dJdE_minus_1": float(abs(tc / (2 * mpmath.pi * dJ) - 1)),
            }
    worst = max(r["abs_ratio_minus_1"] for r in rows.values())
    refuted = worst > float(_THM1_TOL)
    parts = "; ".join(f"{r['T_over_2pi_dJdE'][:22]}… for {n} "
                      f"(|ratio − 2| = {g(r['abs_ratio_minus_2'], 2)})" for n, r in rows.items())
    tc_dev = max(r["abs_tc_over_2pi_dJdE_minus_1"] for r in rows.values())
    evidence = (f"T/(2π dJ/dE) = {parts} at {_THM1_DPS} digits, dJ/dE by mpmath.diff of J; "
                f"the printed relation holds for the contact time, t_c = 2π dJ/dE "
                f"(|t_c/(2π dJ/dE) − 1| ≤ {g(tc_dev, 2)}), so the paper's T = 4π dJ/dE")
    return _result("refuted" if refuted else "verified", evidence,
                   f"refuted if |T/(2π dJ/dE) − 1| > {g(float(_THM1_TOL))} at "
                   f"{_THM1_DPS} digits", rows)


# ==================================================================================
# Theorem 2
# ==================================================================================
def thm2_harmonic() -> dict:
    """x(q(t)) against A sin(Omega0 tau(t)), tau integrated as an ODE state (DOP853, rtol 1e-12).

    Verified if max |x - A sin(Omega0 tau)| / A < 1e-8 on every case (the level
    of the integrator) and the exact solver agrees with the 30-digit physical
    quadrature of the contact time to 1e-13.
    """
    rng = np.random.default_rng(SEED_KM)
    drawn = [(float(K), float(M)) for K, M in 10 ** rng.uniform(-3, 3, size=(2, 2))]
    km_list = [(1.0, 0.75)] + drawn
    rows, worst, teeth = [], 0.0, []
    exact_rows, worst_exact = [], 0.0
    for label, pot, m, v0 in _cases():
        for K, M in km_list:
            hmap = HarmonicMap(pot, m, K, M)
            res = integrate_impact(pot, m, v0, hmap=hmap, rtol=_ODE_RTOL)
            A = v0 * math.sqrt(m / M) / hmap.omega0
            x = hmap.x(np.maximum(res.q, 0.0))
            dev = float(np.max(np.abs(x - A * np.sin(hmap.omega0 * res.tau)))) / A
            tau_err = abs(res.tau_contact * hmap.omega0 / math.pi - 1.0)
            worst = max(worst, dev)
            rows.append({"case": label, "K": K, "M": M, "max_dev_over_A": dev,
                         "tau_contact_rel_err": tau_err})
            if (K, M) == km_list[0]:
                # Negative control: the same x against a half-sine in physical time.
                teeth.append(float(np.max(np.abs(x - A * np.sin(math.pi * res.t / res.contact_time))))
                             / A)
        E = 0.5 * m * v0 * v0
        sol = solve_impact(pot, m, v0)
        ref = act.contact_duration_mp(pot, m, E, dps=30)
        err = float(abs((mpmath.mpf(sol.contact_time) - ref) / ref))
        worst_exact = max(worst_exact, err)
        exact_rows.append({"case": label, "contact_time_exact": sol.contact_time,
                           "contact_time_mp": mpmath.nstr(ref, 20), "rel_err": err})
    ok = worst < _SINUSOID_TOL and worst_exact < _EXACT_RTOL
    evidence = (f"max |x − A sin(Ω0 τ)|/A = {g(worst, 2)} over Hertz, the paper ellipsoid and a "
                f"sum, each with {len(km_list)} (K, M) pairs (DOP853 rtol {g(_ODE_RTOL)}; "
                f"integrator-limited); against physical time the same x deviates by "
                f"{g(min(teeth), 2)}; exact solver vs 30-digit physical quadrature of t_c: "
                f"≤ {g(worst_exact, 2)}")
    return _result("verified" if ok else "refuted", evidence,
                   f"verified if max deviation/amplitude < {g(_SINUSOID_TOL)} and exact t_c "
                   f"within {g(_EXACT_RTOL)} of the mpmath physical integral",
                   {"sinusoid": rows, "physical_time_control": teeth, "exact_vs_mp": exact_rows,
                    "random_KM_seed": SEED_KM})


# ==================================================================================
# K, M cancellation (Remark of section 5)
# ==================================================================================
def _spread(a) -> float:
    a = np.asarray(a, dtype=float)
    return float(np.max(np.abs(a - a[0]) / np.abs(a[0])))


def km_cancellation() -> dict:
    """Do K, M cancel? dt_safe via the map, C(q) at fixed zeta and at fixed C0, over (K, M) pairs.

    As the suite judges it (test_sec5_harmonic.py): the printed Remark includes
    the damping law of Theorem 3, which is written with a fixed C0; refuted if
    that law changes with (K, M) measurably (> 1e-5) while the zeta form and the
    stability bound cancel to round-off; verified if everything cancels.
    """
    dt_spreads, cz_spreads, traj = [], [], []
    for _label, pot, m, v0 in _cases():
        q_max = pot.turning_point(0.5 * m * v0 * v0)
        grid = q_max * np.unique(np.concatenate([np.logspace(-12, 0, 200), np.linspace(0, 1, 801)]))
        vals = [(2.0 / HarmonicMap(pot, m, K, M).omega0) / np.max(HarmonicMap(pot, m, K, M)
                                                                   .dtau_dt(grid))
                for K, M in _KM_PAIRS]
        dt_spreads.append(_spread(vals))
        q = q_max * np.logspace(-6, 0, 60)
        Cs = np.array([UniversalDamping(HarmonicMap(pot, m, K, M), zeta=0.3).C(q)
                       for K, M in _KM_PAIRS])
        cz_spreads.append(float(np.max(np.abs(Cs / Cs[0] - 1))))
    # Fixed C0 = 0.5 (Fig. 1), paper ellipsoid at 0.99 m/s.
    pot, m, v0 = paper_ellipsoid(), PAPER_MASS, 0.99
    q = pot.turning_point(0.5 * m * v0 * v0) * np.logspace(-4, 0, 40)
    laws = [UniversalDamping(HarmonicMap(pot, m, K, M), C0=0.5) for K, M in _KM_PAIRS]
    C0s = np.array([law.C(q) for law in laws])
    c0_spread = float(np.max(np.abs(C0s / C0s[0] - 1)))
    ratio_075 = float(np.mean(C0s[1] / C0s[0]))
    (K0, M0), (K1, M1) = _KM_PAIRS[:2]
    expected = math.sqrt(K0 * M0 / (K1 * M1))
    e_fixed_c0 = {f"K = {law.hmap.K:g}, M = {law.hmap.M:g}":
                  integrate_impact(pot, m, v0, C=law.C, rtol=_ODE_RTOL).restitution
                  for law in laws[:2]}
    # Physical trajectory at fixed zeta for two pairs.
    runs = [integrate_impact(pot, m, v0, rtol=_ODE_RTOL, dense_output=True,
                             C=UniversalDamping(HarmonicMap(pot, m, K, M), zeta=0.3).C)
            for K, M in (_KM_PAIRS[0], _KM_PAIRS[2])]
    t = np.linspace(0, min(r.contact_time for r in runs), 200)
    traj_dev = float(np.max(np.abs(runs[0].sol(t)[0] - runs[1].sol(t)[0])) / runs[0].q_max)
    traj.append(traj_dev)
    cancel = max(dt_spreads) < _ROUNDOFF_TOL and max(cz_spreads) < _ROUNDOFF_TOL
    verdict = "verified" if cancel and c0_spread < _MEASURABLE else (
        "refuted" if cancel else "inconclusive")
    e_vals = list(e_fixed_c0.items())
    evidence = (f"over {len(_KM_PAIRS)} (K, M) pairs the bound Δτ_crit/max dτ/dt varies by "
                f"{g(max(dt_spreads), 2)} and C(q) at fixed ζ by {g(max(cz_spreads), 2)} "
                f"(round-off), q(t) at fixed ζ by {g(traj_dev, 2)} of q_max (ODE); but the "
                f"Theorem 3 law at fixed C0 = 0.5 changes by {g(c0_spread, 3)} "
                f"(C|K=1,M=0.75 / C|K=1,M=1 = {ratio_075:.7f}; √(KM) ratio {expected:.7f}) and "
                f"the restitution with it ({e_vals[1][1]:.6f} at {e_vals[1][0]} vs "
                f"{e_vals[0][1]:.6f} at {e_vals[0][0]}; paper ellipsoid, 0.99 m/s): K, M cancel "
                f"only at fixed ζ = C0/(2√(KM))")
    return _result(verdict, evidence,
                   f"refuted if C(q) at fixed C0 varies by > {g(_MEASURABLE)} over (K, M) while "
                   f"the ζ form and dt_safe cancel to < {g(_ROUNDOFF_TOL)}",
                   {"KM_pairs": _KM_PAIRS, "dt_safe_spread": dt_spreads,
                    "C_fixed_zeta_spread": cz_spreads, "C_fixed_C0_spread": c0_spread,
                    "C_ratio_K1_M075_over_K1_M1": ratio_075,
                    "restitution_fixed_C0": e_fixed_c0, "trajectory_fixed_zeta_dev": traj_dev})


# ==================================================================================
# Theorem 3
# ==================================================================================
def _restitution(pot, m, v0, C) -> float:
    run = integrate_impact(pot, m, v0, C=C, rtol=_ODE_RTOL)
    return run.restitution if run.returned else 0.0


def thm3_damping() -> dict:
    """Restitution spread over v0 under the universal law, a perturbed law and a constant C.

    Verified if the universal spread is at integrator level (< 1e-8, and within
    1e-8 of exp(-pi zeta / sqrt(1 - zeta^2))) and both other spreads exceed it
    by more than three orders of magnitude.
    """
    zeta = 0.3
    e_th = restitution_from_zeta(zeta)
    setups = [
        ("Hertz", _HERTZ, _MASS, (0.1, 1.0, 10.0)),
        ("paper ellipsoid", paper_ellipsoid(), PAPER_MASS, (0.15, 1.5)),
    ]
    rows = []
    for label, pot, m, speeds in setups:
        law = UniversalDamping(HarmonicMap(pot, m), zeta=zeta)
        q_ref = pot.turning_point(0.5 * m * speeds[len(speeds) // 2] ** 2)
        c_const = float(law.C(q_ref))
        variants = {
            "universal": law.C,
            "perturbed C(q)(1+q/q_ref)": lambda q, law=law, q_ref=q_ref: law.C(q) * (1 + q / q_ref),
            "constant C": lambda q, c=c_const: c,
        }
        for name, C in variants.items():
            # A body that never leaves (overdamped creep) has restitution 0.
            es = [_restitution(pot, m, v, C) for v in speeds]
            rows.append({"case": label, "law": name, "speeds": speeds, "restitution": es,
                         "spread": float(max(es) - min(es)),
                         "max_dev_from_theory": float(max(abs(e - e_th) for e in es))})
    uni = [r for r in rows if r["law"] == "universal"]
    other = [r for r in rows if r["law"] != "universal"]
    s_uni = max(r["spread"] for r in uni)
    d_uni = max(r["max_dev_from_theory"] for r in uni)
    s_min_other = min(r["spread"] for r in other)
    ok = s_uni < _E_TOL and d_uni < _E_TOL and s_min_other > _ORDERS * max(s_uni, _E_TOL * 1e-3)
    pert = {r["law"]: r["spread"] for r in other if r["case"] == "Hertz"}
    evidence = (f"restitution spread over v0 (Hertz {', '.join(map(str, setups[0][3]))} m/s, "
                f"ellipsoid {', '.join(map(str, setups[1][3]))} m/s; ζ = {zeta}): universal "
                f"law {g(s_uni, 2)} (|e − e(ζ)| ≤ {g(d_uni, 2)}, e(ζ) = {e_th:.6f}, ODE rtol "
                f"{g(_ODE_RTOL)}); perturbed law {g(pert['perturbed C(q)(1+q/q_ref)'], 3)}, "
                f"constant C {g(pert['constant C'], 3)} (Hertz); smallest non-universal spread "
                f"{g(s_min_other, 3)}")
    return _result("verified" if ok else "refuted", evidence,
                   f"verified if the universal spread < {g(_E_TOL)} and every other law's spread "
                   f"is > {g(_ORDERS)} times larger", {"zeta": zeta, "rows": rows})


# ==================================================================================
# Section 7
# ==================================================================================
def sec7_effective_mass() -> dict:
    """M_eff = 2 m K U / U'^2 against m / (dx/dq)^2; its variation over x; constant iff p = 1.

    Verified if the two forms agree to 1e-12, M_eff varies by < 1e-12 for p = 1
    and by > 1e-3 for every other potential, and the power-law log-log slopes
    equal 2 (1 - p) / (p + 1) to 1e-10.
    """
    K, M, m = 2.0, 0.5, _MASS
    pots = [(f"p={p:g}", PowerLaw(1e6, p), p) for p in (0.5, 1.0, 1.5, 3.0)]
    pots.append(("paper ellipsoid", paper_ellipsoid(), None))
    rows, id_err = [], 0.0
    for label, pot, p in pots:
        hmap = HarmonicMap(pot, m, K, M)
        q = pot.turning_point(0.5 * m) * np.logspace(-3, 0, 60)  # up to q_max at 1 m/s
        x = hmap.x(q)
        meff = hmap.effective_mass(x)
        direct = m / hmap.dxdq(q) ** 2
        err = float(np.max(np.abs(meff / direct - 1)))
        id_err = max(id_err, err)
        variation = float((meff.max() - meff.min()) / meff.max())
        slope = float(np.polyfit(np.log(x), np.log(meff), 1)[0]) if p is not None else math.nan
        rows.append({"potential": label, "identity_rel_err": err, "relative_variation": variation,
                     "loglog_slope": slope,
                     "expected_slope": 2 * (1 - p) / (p + 1) if p is not None else math.nan})
    lin = [r for r in rows if r["potential"] == "p=1"][0]
    others = [r for r in rows if r["potential"] != "p=1"]
    slope_err = max(abs(r["loglog_slope"] - r["expected_slope"]) for r in rows
                    if math.isfinite(r["expected_slope"]))
    ok = (id_err < 1e-12 and lin["relative_variation"] < 1e-12
          and min(r["relative_variation"] for r in others) > 1e-3 and slope_err < _SLOPE_TOL)
    evidence = (f"2mKU/U'² vs m/(dx/dq)²: ≤ {g(id_err, 2)}; relative variation of M_eff over "
                f"three decades of q: {g(lin['relative_variation'], 2)} for p = 1, "
                + ", ".join(f"{r['potential']} {g(r['relative_variation'], 3)}" for r in others)
                + f"; power-law slopes d ln M_eff/d ln x = 2(1−p)/(p+1) to {g(slope_err, 2)}")
    return _result("verified" if ok else "refuted", evidence,
                   "verified if the identity holds to 1e-12, M_eff is constant (1e-12) for p = 1 "
                   "only (others vary > 1e-3) and the slopes match to 1e-10", {"rows": rows})


# ==================================================================================
# Section 9
# ==================================================================================
def sec9_power_law() -> dict:
    """Log-log slope of U'/sqrt(U) against (p - 1)/2; UniversalDamping.C against Tsuji c q^e.

    Verified if every slope is within 1e-10 and the two forms of C agree to 1e-13.
    """
    rows, slope_err, c_err = [], 0.0, 0.0
    for p in (0.5, 1.0, 1.5, 2.0, 3.0, 5.0):
        pot = PowerLaw(1e6, p)
        q = pot.q_scale * np.logspace(-3, 3, 60)
        slope = float(np.polyfit(np.log(q), np.log(pot.dU(q) / np.sqrt(pot.U(q))), 1)[0])
        law = UniversalDamping(HarmonicMap(pot, _MASS, 37.0, 0.02), zeta=0.3)
        c, e = tsuji_coefficient(pot, _MASS, 0.3)
        err_c = float(np.max(np.abs(law.C(q) / (c * q**e) - 1)))
        slope_err = max(slope_err, abs(slope - (p - 1) / 2))
        c_err = max(c_err, err_c)
        rows.append({"p": p, "slope": slope, "expected": (p - 1) / 2, "tsuji_rel_err": err_c})
    ok = slope_err < _SLOPE_TOL and c_err < _ROUNDOFF_TOL
    hertz = [r for r in rows if r["p"] == 1.5][0]
    evidence = (f"slope of U'/√U over six decades of q equals (p−1)/2 to {g(slope_err, 2)} for "
                f"p ∈ {{0.5, 1, 1.5, 2, 3, 5}} (Hertz: {hertz['slope']:.12f}); C(q) of Theorem 3 "
                f"equals Tsuji's c q^((p−1)/2) to {g(c_err, 2)}")
    return _result("verified" if ok else "refuted", evidence,
                   f"verified if |slope − (p−1)/2| < {g(_SLOPE_TOL)} and C matches Tsuji to "
                   f"{g(_ROUNDOFF_TOL)}", {"rows": rows})


# ==================================================================================
# Section 10: stiffening domain
# ==================================================================================
def sec10_stiffening() -> dict:
    """Root of 2UU'' - U'^2 in units of a (mpmath, 30 digits) against the printed 0.735.

    Verified if the root truncated to the printed digits is the printed value
    (so 2UU'' >= U'^2 holds on all of (0, 0.735 a]), the sampled indicator is
    >= 0 there and negative beyond the root.
    """
    pot = paper_ellipsoid()
    a = pot.a
    with mpmath.workdps(30):
        root = mpmath.findroot(
            lambda d: (2 * pot.U(d) * pot.d2U(d) - pot.dU(d) ** 2) / pot.dU(d) ** 2,
            (mpmath.mpf(0.7) * a, mpmath.mpf(0.77) * a), solver="anderson")
        u = root / a
    printed = STIFFENING_LIMIT_PRINTED
    nd = len(printed.split(".")[1])
    truncated = f"{math.floor(float(u) * 10**nd) / 10**nd:.{nd}f}"
    inside = stiffening_indicator(pot, np.linspace(1e-6, float(printed), 2001) * a)
    beyond = stiffening_indicator(pot, np.array([float(u) + 1e-3, 1.0, 1.5, 1.9]) * a)
    ok = truncated == printed and float(inside.min()) > -1e-12 and bool(np.all(beyond < 0))
    evidence = (f"2UU'' − U'² changes sign at δ = {mpmath.nstr(u, 10)} a (30-digit root; "
                f"independent of b, c, Kn for α = 0.5), printed {printed} a; the indicator "
                f"(2UU''−U'²)/U'² is ≥ {g(float(inside.min()), 2)} on (0, {printed} a] and "
                f"negative beyond ({g(float(beyond.max()), 3)} at {float(u) + 1e-3:.4f} a)")
    return _result("verified" if ok else "refuted", evidence,
                   "verified if the root, truncated to the printed digits, equals the printed "
                   "limit and the indicator has the claimed sign",
                   {"root_over_a": mpmath.nstr(u, 20), "printed": printed,
                    "min_indicator_inside": float(inside.min()),
                    "indicator_beyond": beyond.tolist()})


# ==================================================================================
# Table 1
# ==================================================================================
_COLUMNS = ("delta_max", "max_force", "dt_safe")


def table1() -> tuple[dict, list[dict]]:
    """Table 1 recomputed at 50 digits; refuted if any cell differs at the printed digits.

    Returns the verdict and the rows (one per speed, each column printed /
    computed / match / difference in units of the printed last digit).
    """
    cells = table1_cells()
    by_v: dict[str, dict] = {v: {"v0": v} for v in TABLE1_PRINTED}
    bad = []
    for c in cells:
        d = c.to_dict()
        by_v[c.v0][c.column] = {k: d[k] for k in ("unit", "printed", "computed", "computed_rounded",
                                                  "match", "difference_in_last_digit")}
        if not c.match:
            bad.append(c)
    rows = list(by_v.values())
    names = {"delta_max": "δmax", "max_force": "U'(δmax)", "dt_safe": "Δt_safe"}
    if bad:
        evidence = (f"{len(bad)} of {len(cells)} cells differ at the printed digits: "
                    + "; ".join(f"v0 = {c.v0} {names[c.column]} computed {c.computed_rounded} vs "
                                f"printed {c.printed} {c.unit} ({c.difference_in_last_digit:+.2f} "
                                f"units of the last digit)" for c in bad))
    else:
        evidence = f"all {len(cells)} cells match at the printed digits (50-digit recomputation)"
    verdict = _result("refuted" if bad else "verified", evidence,
                      "refuted if any computed cell, rounded to the printed digits, differs from "
                      "the printed value", {"mismatches": len(bad), "cells": len(cells)})
    return verdict, rows
