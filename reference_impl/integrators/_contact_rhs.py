"""The contact's equations of motion as `integrate_impact` hands them to solve_ivp.

m q'' = -U'(q) - C(q) q' written in the two dimensionless independent variables of
`reference_impl.integrators.ivp` (s = t / t_s in phases 1-2, sigma = q / q_s in
phase 3), with every evaluation kept defined at q <= 0 (`ContactRHS`), and a budget
of right-hand-side evaluations (`Budgeted`). How the phases, events and dense output
use them is `reference_impl.integrators.ivp`.
"""

from __future__ import annotations

import math

import numpy as np

from reference_impl.potentials.base import Potential
from reference_impl.theory.harmonic_map import HarmonicMap

__all__ = ["Budgeted", "ContactRHS"]

# Sentinel value of the zero-force event function out of contact: positive, so
# that returning to q <= 0 is never mistaken for a (downward) zero crossing.
_OUT_OF_CONTACT_FORCE_SIGN = 1.0


class ContactRHS:
    """Right-hand sides and event functions of the contact, with guards at q <= 0.

    No phase steps past q = 0 (phase 3 ends exactly there), but every
    evaluation stays defined whatever state a caller passes (Potential.U raises
    for q < 0):

    * q < 0: out of contact, elastic force, damping and d tau/dt are 0;
    * q == 0: the potential's limit values; a non-finite limit (C(q) and
      d tau/dt ~ q^((n-2)/2) for a leading exponent n < 2) is replaced by 0.
      The singularity is integrable, the value at one point does not change the
      solution, and the step-size control resolves the neighbourhood.
    """

    def __init__(self, potential: Potential, m: float, C, hmap: HarmonicMap | None, *, q_s, t_s):
        self.pot = potential
        self.m = m
        self.C = C
        self.hmap = hmap
        self.q_s = q_s  # overlap scale (m): sigma = q / q_s in phase 3
        self.t_s = t_s  # time scale (s): s = t / t_s

    def force(self, q: float) -> float:
        """Elastic force U'(q) (N), 0 out of contact."""
        if q < 0:
            return 0.0
        f = float(self.pot.dU(q))
        return f if math.isfinite(f) else 0.0

    def damping(self, q: float) -> float:
        """Damping coefficient C(q) (kg/s), 0 out of contact or for C = None."""
        if self.C is None or q < 0:
            return 0.0
        with np.errstate(divide="ignore", invalid="ignore"):
            c = float(np.asarray(self.C(q), dtype=float).reshape(-1)[0])
        return c if math.isfinite(c) else 0.0

    def rate(self, q: float) -> float:
        """d tau / dt (virtual s per s), 0 out of contact."""
        if q < 0:
            return 0.0
        with np.errstate(divide="ignore", invalid="ignore"):
            r = float(self.hmap.dtau_dt(q))
        return r if math.isfinite(r) else 0.0

    def total_force(self, q: float, v: float) -> float:
        """U'(q) + C(q) v (N); a positive sentinel out of contact (see module constants)."""
        if q <= 0:
            return _OUT_OF_CONTACT_FORCE_SIGN
        return self.force(q) + self.damping(q) * v

    # -- phases 1, 2: y = (q, v[, tau]) of s = t / t_s ----------------------------------
    def in_s(self, s: float, y: np.ndarray) -> list[float]:
        q, v = float(y[0]), float(y[1])
        a = -(self.force(q) + self.damping(q) * v) / self.m
        out = [self.t_s * v, self.t_s * a]
        return out if self.hmap is None else out + [self.t_s * self.rate(q)]

    # -- phase 3: y = (s, v[, tau]) of sigma = q / q_s -----------------------------------
    def in_sigma(self, sigma: float, y: np.ndarray) -> list[float]:
        q, v = sigma * self.q_s, float(y[1])
        a = -(self.force(q) + self.damping(q) * v) / self.m
        dq_over_v = self.q_s / v  # dt per unit sigma (s)
        out = [dq_over_v / self.t_s, a * dq_over_v]
        return out if self.hmap is None else out + [self.rate(q) * dq_over_v]


class Budgeted:
    """`ContactRHS` with a budget of right-hand-side evaluations (``max_nfev``)."""

    def __init__(self, rhs, budget: int, what: str):
        self._rhs, self._left, self._budget, self._what = rhs, budget, budget, what

    def __getattr__(self, name):
        return getattr(self._rhs, name)

    def _spend(self):
        self._left -= 1
        if self._left < 0:
            raise RuntimeError(
                f"integrate_impact: budget of {self._budget} right-hand-side evaluations "
                f"(max_nfev) spent before q returned to 0 for {self._what}: the body "
                "creeps towards q = 0 (an overdamped law?)"
            )

    def in_s(self, s, y):
        self._spend()
        return self._rhs.in_s(s, y)

    def in_sigma(self, sigma, y):
        self._spend()
        return self._rhs.in_sigma(sigma, y)
