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

__all__ = ["SaturatingForce"]

# Below this x = q/q_s the saturating energy q_s F0 (x - atan x) is taken from
# its series, because the difference loses all digits as x -> 0 (also read by the
# Verlet kernel, which evaluates the same closed form compiled).
_SAT_SERIES_X = 1e-2


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
            series = x**3 / 3 - x**5 / 5 + x**7 / 7
            with np.errstate(invalid="ignore"):
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
