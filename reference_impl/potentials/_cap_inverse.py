"""The closed-form inverse of a volumetric cap's energy: q with U(q) = u (issue 38).

The cap's energy is U = Kn V^A / A (A = alpha + 1) with the cubic overlap volume
V = c0 (a q^2 - q^3 / 3), c0 = pi b c / a^2 (`reference_impl.potentials.volumetric`).
Both steps invert in closed form:

1. V = t^(1/A), t = A u / Kn, as ``t ** e * (1 + c ln t)`` with e = fl(1/A) and
   c = 1/A - e (computed exactly, in rationals, from the float alpha; A is alpha + 1
   exactly, as the 30-digit path forms it). ``t ** e`` alone is off by t^(1/A - e),
   i.e. ~5.5e-17 |ln t|: 1.5e-15 at the scenes' t ~ 1e-12 (the compiled node loop,
   `reference_impl.exact._cap_nodes._cap_powers`, makes the same correction).
2. y = q / a solves y^2 (1 - y/3) = omega, omega = V / (pi b c a), on 0 <= y <= 2:
   y = 4 sin(psi) sin(psi + pi/3), psi = asin(sqrt(3 omega) / 2) / 3, then one Newton
   step on the cubic, whose size confirms the closed form (accepted within _STEP_MAX).

This replaced the generic bracketed root finder (`Potential._numeric_inverse`), ~190 us
of a ~290 us one-shot sphere impact, with ~2 us of Python floats (one energy, the
turning point) or one numpy pass (many energies). Accuracy against the 30-digit inverse
(verification/test_cap_inverse.py): q within `ULPS` eps * max(1, kappa(y)) relative,
kappa(y) = (1 - y/3) / (2 - y) being the cubic's own conditioning d ln y / d ln omega
(at y -> 2, the body's far pole, q is ill-conditioned for any method). Where the closed
form is not safe (t or omega outside the normal range, omega above the cubic's maximum
4/3 by round-off, a Newton step larger than _STEP_MAX) it returns nan and the caller
takes the numeric inverse, which also names a refusal (an energy U never reaches).
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np

__all__ = ["ULPS", "CapInverse"]

# Bound of the closed form against the exact inverse, in eps relative to q, before the
# cubic's conditioning kappa(y) multiplies it: V = t^(1/A) carries <= 1 ulp from pow, 1 from
# t's two roundings (divided by A >= 1), 1 from the correction product; omega 2 more (the
# float pi b c a and the product); the Newton step's residual is evaluated to ~3 ulps of
# omega; q = a y one rounding. 8 ulps of omega times kappa, plus q's own rounding, is at
# most 9 eps * max(1, kappa); measured <= 2.2 eps * max(1, kappa) over random caps and
# energies (verification/test_cap_inverse.py), so 12 leaves a margin for libm's asin/sin.
ULPS = 12.0
# Largest Newton step accepted, relative to y: the closed form is within ~4 ulps, so a
# step above 1e-10 means it failed (a libm far off, or omega at the double root y = 2,
# where both it and Newton lose digits to the conditioning); the numeric inverse then runs.
_STEP_MAX = 1e-10
# omega and t must be normal numbers with room: y^2 ~ omega must not underflow in the
# Newton residual, and t^e must not leave the normal range (a cap below ~1e-290 of its
# scale, or an energy near float64's ends, goes to the numeric inverse).
_TINY = 1e-290
_HUGE = 1e290
_PI_3 = math.pi / 3.0
# The cubic's maximum: omega = 4/3 at y = 2 (q = 2a, the body's far pole).
_OMEGA_TOP = 4.0 / 3.0


class CapInverse:
    """q (m) with U(q) = u (J) for the cap U = Kn V^A / A, V = c0 (a q^2 - q^3 / 3).

    Parameters
    ----------
    Kn : float
        Volumetric stiffness, J / m^(3 A).
    alpha : float
        Regularisation exponent (> 0); A = alpha + 1, formed exactly.
    a : float
        Semi-axis along the impact, m (the cap's domain is 0 <= q <= 2a).
    bc : float
        Product b c of the transverse semi-axes, m^2 (c0 = pi bc / a^2).
    """

    __slots__ = ("_a", "_c", "_e", "_to_omega", "_to_t")

    def __init__(self, Kn: float, alpha: float, a: float, bc: float):
        A = Fraction(alpha) + 1
        inv_A = 1 / A
        self._e = float(inv_A)
        # The exponent's residual 1/A - fl(1/A): exact rationals, rounded once.
        self._c = float(inv_A - Fraction(self._e))
        # t = u A / Kn; nan when A / Kn is beyond float64 (Kn ~ 1e-308: every energy then
        # goes to the numeric inverse).
        try:
            self._to_t = float(A / Fraction(Kn))
        except OverflowError:
            self._to_t = math.nan
        # omega = w / a^3 = V / (c0 a^3) = V / (pi bc a); 0 or inf for an extreme cap sends
        # every energy to the numeric inverse too.
        den = math.pi * bc * a
        self._to_omega = 1.0 / den if den > 0.0 else math.inf
        self._a = a

    def one(self, u: float) -> float:
        """q for one energy u >= 0 (J) in Python floats (~2 us); nan where the closed form
        does not take it (see the module docstring)."""
        if u == 0.0:
            return 0.0
        t = u * self._to_t
        if not (_TINY < t < _HUGE):
            return math.nan
        lt = math.log(t)
        v = t**self._e * (1.0 + self._c * lt)
        om = v * self._to_omega
        if not (_TINY < om <= _OMEGA_TOP):
            return math.nan
        psi = math.asin(math.sqrt(0.75 * om)) / 3.0
        y = 4.0 * math.sin(psi) * math.sin(psi + _PI_3)
        # Newton on f(y) = y^2 (1 - y/3) - omega, f' = y (2 - y).
        fp = y * (2.0 - y)
        if not fp > 0.0:
            return math.nan
        step = (y * y * (1.0 - y / 3.0) - om) / fp
        if not abs(step) <= _STEP_MAX * y:
            return math.nan
        q = self._a * (y - step)
        return q if _TINY < q < _HUGE else math.nan

    def many(self, u: np.ndarray) -> np.ndarray:
        """`one` at every energy of a float64 array (J), element by element: each energy
        gets the bits it gets alone (numpy's sin and pow differ from libm's by an ulp, so
        a vectorised pass would make q depend on the array it came in); ~2 us an energy,
        where the numeric inverse took ~5 us an energy on 1000 of them."""
        one = self.one
        return np.array([one(x) for x in np.asarray(u, dtype=float).ravel().tolist()]).reshape(
            np.shape(u)
        )
