"""Section 9: for power laws the universal law is Tsuji's C ~ q^((p-1)/2)."""

from __future__ import annotations

import functools

import numpy as np

from reference_impl.claims._base import Measurement, g
from reference_impl.claims._cases import MASS
from reference_impl.claims._tolerances import ROUNDOFF_TOL, SLOPE_TOL
from reference_impl.potentials import PowerLaw
from reference_impl.theory.damping import UniversalDamping, tsuji_coefficient
from reference_impl.theory.harmonic_map import HarmonicMap

ID = "sec9-power-law"
SECTION = "9"
STATEMENT = (
    "For U = k q^(p+1)/(p+1) the universal law is C(q) proportional to q^((p-1)/2) "
    "(Tsuji damping, q^(1/4) for Hertz)."
)

# Softening, linear, Hertz and stiffer laws: every regime of section 9.
EXPONENTS = (0.5, 1.0, 1.5, 2.0, 3.0, 5.0)
# Damping ratio of the Tsuji comparison (the identity holds for any 0 < zeta < 1).
ZETA = 0.3


@functools.cache
def measure(quick: bool = False) -> Measurement:
    """Verified if every slope is within SLOPE_TOL of (p-1)/2 and C matches Tsuji's
    c q^((p-1)/2) to ROUNDOFF_TOL."""
    rows, slope_err, c_err = [], 0.0, 0.0
    for p in EXPONENTS:
        pot = PowerLaw(1e6, p)
        q = pot.q_scale * np.logspace(-3, 3, 60)
        slope = float(np.polyfit(np.log(q), np.log(pot.dU(q) / np.sqrt(pot.U(q))), 1)[0])
        law = UniversalDamping(HarmonicMap(pot, MASS, 37.0, 0.02), zeta=ZETA)
        c, e = tsuji_coefficient(pot, MASS, ZETA)
        err_c = float(np.max(np.abs(law.C(q) / (c * q**e) - 1)))
        slope_err = max(slope_err, abs(slope - (p - 1) / 2))
        c_err = max(c_err, err_c)
        rows.append({"p": p, "slope": slope, "expected": (p - 1) / 2, "tsuji_rel_err": err_c})
    ok = slope_err < SLOPE_TOL and c_err < ROUNDOFF_TOL
    hertz = [r for r in rows if r["p"] == 1.5][0]
    evidence = (
        f"slope of U'/√U over six decades of q equals (p−1)/2 to {g(slope_err, 2)} for "
        f"p ∈ {{{', '.join(f'{p:g}' for p in EXPONENTS)}}} (Hertz: "
        f"{hertz['slope']:.12f}); C(q) of Theorem 3 equals Tsuji's c q^((p−1)/2) to "
        f"{g(c_err, 2)}"
    )
    counter = None if ok else {"rows": rows}
    return Measurement(
        ID,
        "verified" if ok else "refuted",
        evidence,
        f"verified if |slope − (p−1)/2| < {g(SLOPE_TOL)} and C matches Tsuji to {g(ROUNDOFF_TOL)}",
        {"rows": rows},
        counter,
        headline=(f"C ∝ q^((p−1)/2) to {g(c_err, 2)}; Hertz exponent {hertz['slope']:.12f}"),
    )
