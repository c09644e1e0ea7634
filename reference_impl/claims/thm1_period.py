"""Theorem 1 (section 4): the period of the contact oscillation is T(E) = 2 pi dJ/dE.

Measured at 40 digits: the paper's period T (four times its quarter period
int_0^qmax dq/qdot), the one-sided contact time t_c and dJ/dE by mpmath.diff
of J, on Hertz, the paper ellipsoid and a sum of power laws.
"""

from __future__ import annotations

import functools

import mpmath

from reference_impl.claims._base import Measurement, g
from reference_impl.potentials import PowerLaw
from reference_impl.studies.paper import PAPER_MASS, PAPER_V0_MIDDLE, paper_ellipsoid
from reference_impl.theory import action as act

ID = "thm1-period"
SECTION = "4 (Theorem 1)"
STATEMENT = (
    "J(E) = sqrt(2m)/pi * int_0^qmax sqrt(E-U) dq is strictly increasing and the period of the "
    "contact oscillation, four times the quarter-period int_0^qmax dq/qdot, is T(E) = 2 pi dJ/dE."
)

# The statement as printed (where, equation number or None, LaTeX; whitespace-normalised),
# checked verbatim against the paper's .tex by verification/test_tools_erratum.py.
PRINTED = ("section 4, Theorem 1", 3, r"T(E)=2\pi\,\frac{dJ}{dE}.")

# Working precision of the measurement: 40 digits, far beyond any float effect.
DPS = 40
# A relation that holds agrees to ~1e-45 at DPS (10 guard digits in the mpmath routes);
# 1e-20 leaves 25 orders of headroom and is still 19 orders below a factor-2 error.
RELATION_TOL = 1e-20


def cases() -> dict:
    """name -> (potential, mass kg, energy J): Hertz, the paper ellipsoid at 0.99 m/s, a sum."""
    return {
        "Hertz": (PowerLaw(1e6, 1.5), 0.05, 0.0123),
        "paper ellipsoid": (paper_ellipsoid(), PAPER_MASS, 0.5 * PAPER_MASS * PAPER_V0_MIDDLE**2),
        "sum linear + q^3.5": (PowerLaw(1e5, 1.0) + PowerLaw(1e8, 2.5), 0.02, 0.03),
    }


@functools.cache
def relation(name: str) -> dict:
    """T, t_c, dJ/dE (mpf at DPS digits) and the ratios T/(2 pi dJ/dE), t_c/(2 pi dJ/dE)."""
    pot, m, E = cases()[name]
    with mpmath.workdps(DPS + 10):
        T = act.period_mp(pot, m, E, dps=DPS)
        tc = act.contact_duration_mp(pot, m, E, dps=DPS)
        dJ = act.dJ_dE_mp(pot, m, E, dps=DPS)
        return {
            "E": E,
            "T": T,
            "t_c": tc,
            "dJ_dE": dJ,
            "T_ratio": T / (2 * mpmath.pi * dJ),
            "tc_ratio": tc / (2 * mpmath.pi * dJ),
        }


@functools.cache
def measure(quick: bool = False) -> Measurement:
    """Refuted if |T/(2 pi dJ/dE) - 1| > RELATION_TOL on any case (40 digits)."""
    rows = {}
    for name in cases():
        r = relation(name)
        rows[name] = {
            "E_J": r["E"],
            "T_s": mpmath.nstr(r["T"], 25),
            "dJ_dE_s": mpmath.nstr(r["dJ_dE"], 25),
            "T_over_2pi_dJdE": mpmath.nstr(r["T_ratio"], 30, strip_zeros=False),
            "abs_ratio_minus_1": float(abs(r["T_ratio"] - 1)),
            "abs_ratio_minus_2": float(abs(r["T_ratio"] - 2)),
            "abs_tc_over_2pi_dJdE_minus_1": float(abs(r["tc_ratio"] - 1)),
        }
    worst_name = max(rows, key=lambda n: rows[n]["abs_ratio_minus_1"])
    worst = rows[worst_name]["abs_ratio_minus_1"]
    refuted = worst > RELATION_TOL
    parts = "; ".join(
        f"{r['T_over_2pi_dJdE'][:22]}… for {n} (|ratio − 2| = {g(r['abs_ratio_minus_2'], 2)})"
        for n, r in rows.items()
    )
    tc_dev = max(r["abs_tc_over_2pi_dJdE_minus_1"] for r in rows.values())
    evidence = (
        f"T/(2π dJ/dE) = {parts} at {DPS} digits, dJ/dE by mpmath.diff of J; "
        f"the printed relation holds for the contact time, t_c = 2π dJ/dE "
        f"(|t_c/(2π dJ/dE) − 1| ≤ {g(tc_dev, 2)}), so the paper's T = 4π dJ/dE"
    )
    counter = (
        {
            "case": worst_name,
            "T_over_2pi_dJdE": rows[worst_name]["T_over_2pi_dJdE"],
            "abs_ratio_minus_1": worst,
        }
        if refuted
        else None
    )
    return Measurement(
        ID,
        "refuted" if refuted else "verified",
        evidence,
        f"refuted if |T/(2π dJ/dE) − 1| > {g(RELATION_TOL)} at {DPS} digits",
        rows,
        counter,
        headline=(
            f"with the paper's J and T = 4 × quarter period, T/(2π dJ/dE) = "
            f"{rows[worst_name]['T_over_2pi_dJdE'][:5]} at {DPS} digits "
            f"(|ratio − 2| ≤ {g(max(r['abs_ratio_minus_2'] for r in rows.values()), 2)}); "
            f"2π dJ/dE is the contact time (to {g(tc_dev, 2)})"
        ),
    )


def corrected(m: dict, r: dict | None = None) -> tuple[str, str]:
    """This claim's erratum: the contract is `reference_impl.claims.Claim.corrected`."""
    dev2 = max(r["abs_ratio_minus_2"] for r in m.values())
    dtc = max(r["abs_tc_over_2pi_dJdE_minus_1"] for r in m.values())
    cases = ", ".join(f"{n} {r['T_over_2pi_dJdE'][:12]}" for n, r in m.items())
    return (
        "T(E) = 4π dJ/dE (Eq. 3 and the last line of the proof); equivalently the contact "
        "time t_c = T/2 = 2π dJ/dE.",
        f"T/(2π dJ/dE) at 40 digits: {cases}; |ratio − 2| ≤ {g(dev2, 2)}; "
        f"|t_c/(2π dJ/dE) − 1| ≤ {g(dtc, 2)}.",
    )
