"""A stiffening-then-softening contact: U'(q) = F0 x^2 / (1 + x^2), x = q / q_s.

The third geometry class of section 6 (an interior supremum of U'/sqrt(2U)); the
critical-step map runs it, and its closed form is compiled into the Verlet kernel.
"""

from __future__ import annotations

import math

import numpy as np

from reference_impl.errors import HCVInputError
from reference_impl.potentials._families import register_family
from reference_impl.potentials._terms import saturating_row
from reference_impl.potentials.base import Potential

__all__ = ["SaturatingForce", "saturating_series"]

# Below this x = q/q_s the saturating energy q_s F0 (x - atan x) is taken from its
# series, because the difference cancels: x - atan x ~ x^3/3 loses a factor 3/x^2 of
# relative precision (75 ulps at x = 0.2, 48 at 0.25). At and above 0.25 that is
# <= 48 x 1.1e-16 = 5e-15 relative; below, the series to x^29 (14 terms) truncates at
# 0.25^28 x 3/31 = 1.4e-18 relative. (Up to 2026-11 the switch was at 0.01 with three
# terms: 3e-13 off on both sides, which the near-critical tail of the general-law
# solver magnified past its error bound.) Also read by the Verlet kernel, which
# evaluates the same closed form compiled (`saturating_series`).
_SAT_SERIES_X = 0.25
# (-1)^k / (2k + 3), k = 0..13: x - atan x = x^3 sum_k c_k x^(2k).
_SAT_SERIES = tuple((-1.0) ** k / (2 * k + 3) for k in range(14))


def saturating_series(x):
    """x - atan x by its series (dimensionless; used for 0 <= x < `_SAT_SERIES_X`), for a
    float or elementwise a numpy array; numba-compilable (the Verlet kernel compiles this
    same function)."""
    x2 = x * x
    s = _SAT_SERIES[13]
    for k in range(12, -1, -1):
        s = s * x2 + _SAT_SERIES[k]
    return s * x2 * x


@register_family
class SaturatingForce(Potential):
    """Stiffening-then-softening contact, U'(q) = F0 x^2 / (1 + x^2), x = q / q_s.

    U'/sqrt(2U) vanishes at q -> 0 (U ~ x^3) and as q -> infinity (U' -> F0), so
    its supremum along a long enough path is interior: the third geometry class
    of section 6. With F0 = 1 N and q_s = 1 m this is U'(q) = q^2 / (1 + q^2).

    Parameters
    ----------
    F0 : float
        Saturation force (N, > 0).
    q_s : float
        Crossover overlap (m, > 0).
    """

    leading_exponent = 3.0
    family = "saturating"
    scene_keys = ((), ("F0", "q_s"))
    label = "saturating force U' = F0 x^2 / (1 + x^2), x = q / q_s (F0 in N, q_s in m)"

    def __init__(self, F0: float = 1.0, q_s: float = 1.0):
        if not (math.isfinite(F0) and F0 > 0 and math.isfinite(q_s) and q_s > 0):
            raise HCVInputError(
                f"SaturatingForce needs F0 > 0 and q_s > 0, got F0={F0!r}, q_s={q_s!r}"
            )
        self.F0, self.q_s = float(F0), float(q_s)
        self.q_scale = self.q_s

    def _U(self, q):
        ns = self._ns(q)
        x = q / self.q_s
        if ns is np:
            x = np.asarray(x, dtype=float)
            with np.errstate(invalid="ignore", over="ignore"):
                series = saturating_series(np.minimum(x, _SAT_SERIES_X))
                exact = x - np.arctan(x)
            return self.F0 * self.q_s * np.where(x < _SAT_SERIES_X, series, exact)
        return self.F0 * self.q_s * (x - ns.atan(x))

    def _dU(self, q):
        x = q / self.q_s
        return self.F0 * x**2 / (1 + x**2)

    def _d2U(self, q):
        x = q / self.q_s
        return self.F0 / self.q_s * 2 * x / (1 + x**2) ** 2

    def _term_rows(self):
        return [saturating_row(self.F0, self.q_s)]

    def params(self) -> dict:
        return {"F0": self.F0, "q_s": self.q_s}

    def __repr__(self) -> str:
        return f"SaturatingForce(F0={self.F0!r}, q_s={self.q_s!r})"
