"""Power-law contact potentials U(q) = k q^(p+1) / (p+1) (section 9).

p = 1 is the linear spring, p = 3/2 the Hertz contact, p < 1 a softening
contact. The inverse of U and the action/period integrals have closed forms,
which the suite uses as independent references.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from reference_impl.potentials._checks import positive
from reference_impl.potentials._families import register_family
from reference_impl.potentials._terms import power_row
from reference_impl.potentials.base import Potential

__all__ = ["PowerLaw"]


@register_family
class PowerLaw(Potential):
    """Power-law potential U(q) = k q^(p+1) / (p+1), force U'(q) = k q^p.

    Parameters
    ----------
    k : float
        Stiffness coefficient, N / m^p (> 0).
    p : float
        Force exponent (> 0): 1 linear, 1.5 Hertz, < 1 softening.
    """

    family = "power"
    scene_keys = (("k", "p"), ())
    label = "power law U' = k q^p (k in N/m^p; p the force exponent, Hertz 1.5)"

    def __init__(self, k: float, p: float):
        self.k = positive("k", k, "PowerLaw")
        self.p = positive("p", p, "PowerLaw")
        self.leading_exponent = self.p + 1.0
        self.leading_coefficient = self.k / self.leading_exponent
        # Overlap at which U = 1 J: a natural starting point for bracket searches.
        self.q_scale = float((self.leading_exponent / self.k) ** (1.0 / self.leading_exponent))

    def _U(self, q):
        return self.k * q ** (self.p + 1) / (self.p + 1)

    def _dU(self, q):
        return self.k * q**self.p

    def _d2U(self, q):
        if self.p == 1:
            return self.k + 0 * q
        with np.errstate(divide="ignore"):
            return self.p * self.k * q ** (self.p - 1)

    def _inverse(self, u: np.ndarray) -> np.ndarray:
        # Exact inverse; U is unbounded, so every energy has a turning point.
        return (self.leading_exponent * np.asarray(u, float) / self.k) ** (
            1.0 / self.leading_exponent
        )

    def check_monotone(self, q_max: float) -> None:
        # U' = k q^p > 0 for every q > 0 whenever k > 0, which __init__ enforces.
        return None

    def _term_rows(self):
        # n = leading_exponent (p + 1.0) and p itself: the exact solver reads n, the
        # Verlet force p, each as this class computes it.
        return [power_row(self.k, self.leading_exponent, self.p)]

    def params(self) -> dict[str, Any]:
        return {"k": self.k, "p": self.p}

    def __repr__(self) -> str:
        return f"PowerLaw(k={self.k!r}, p={self.p!r})"
