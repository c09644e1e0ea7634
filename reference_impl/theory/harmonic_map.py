"""The energy-based harmonic regularisation of Theorem 2 and section 7.

x(q) = sqrt(2 U(q) / K) and d tau / dt = sqrt(M / m) dx/dq turn the contact
m q'' + U'(q) = 0 into M x'' + K x = 0 (primes: d/d tau). The map is monotone,
so q(x) exists; it is computed through the potential's inverse of U.
"""

from __future__ import annotations

import math

import numpy as np

from reference_impl.errors import HCVInputError
from reference_impl.potentials._checks import positive
from reference_impl.potentials.base import Potential, is_mp

__all__ = ["HarmonicMap"]


class HarmonicMap:
    """Energy coordinate x(q) and reparametrised time for one potential and mass.

    Parameters
    ----------
    potential : Potential
        The contact potential U(q).
    m : float
        Physical mass in kg (> 0).
    K, M : float
        Arbitrary positive reference stiffness (N/m) and mass (kg) of the
        virtual oscillator; Omega0 = sqrt(K/M).
    """

    def __init__(self, potential: Potential, m: float, K: float = 1.0, M: float = 1.0):
        if not isinstance(potential, Potential):
            raise HCVInputError(f"potential must be a Potential, got {potential!r}")
        self.potential = potential
        self.m = positive("m", m, "HarmonicMap")
        self.K = positive("K", K, "HarmonicMap")
        self.M = positive("M", M, "HarmonicMap")

    @property
    def omega0(self) -> float:
        """Virtual natural frequency Omega0 = sqrt(K / M) (1/s of virtual time)."""
        return math.sqrt(self.K / self.M)

    def x(self, q):
        """Energy coordinate x(q) = sqrt(2 U(q) / K) (units of sqrt(J / (N/m)))."""
        U = self.potential.U(q)
        return (2 * U / self.K) ** 0.5 if is_mp(q) else np.sqrt(2 * U / self.K)

    def dxdq(self, q):
        """Gradient dx/dq = U'(q) / sqrt(2 K U(q)).

        At q = 0 the value is the limit: 0 when U vanishes faster than q^2
        (leading exponent n > 2), infinite when n < 2, and sqrt(U''(0)/K) for n = 2.
        """
        pot = self.potential
        if is_mp(q):
            if q == 0:
                return self._dxdq_at_zero()
            return pot.dU(q) / (2 * self.K * pot.U(q)) ** 0.5
        arr = np.asarray(q, dtype=float)
        U = np.atleast_1d(pot.U(arr))
        dU = np.atleast_1d(pot.dU(arr))
        with np.errstate(divide="ignore", invalid="ignore"):
            out = dU / np.sqrt(2 * self.K * U)
        out = np.where(U > 0, out, self._dxdq_at_zero())
        return float(out[0]) if arr.ndim == 0 else out.reshape(arr.shape)

    def _dxdq_at_zero(self) -> float:
        n = self.potential.leading_exponent
        if n > 2:
            return 0.0
        if n < 2:
            return math.inf
        # n = 2: U ~ c q^2 exactly, so U''(0) = 2c (no float limit needed).
        c = self.potential.leading_coefficient
        d2U0 = 2.0 * c if c is not None else float(self.potential.d2U(0.0))
        return math.sqrt(d2U0 / self.K)

    def q_of_x(self, x):
        """Inverse map q(x): the overlap with U(q) = K x^2 / 2 (x >= 0)."""
        x = np.asarray(x, dtype=float)
        if np.any(~np.isfinite(x)) or np.any(x < 0):
            raise HCVInputError(
                f"x must be finite and >= 0, got {x[~np.isfinite(x) | (x < 0)].flat[0]!r}"
            )
        return self.potential.inverse(0.5 * self.K * x**2)

    def dtau_dt(self, q):
        """Time-reparametrisation rate d tau / dt = sqrt(M / m) dx/dq (1/s)."""
        return math.sqrt(self.M / self.m) * self.dxdq(q)

    def effective_mass(self, x):
        """Position-dependent mass of the point-canonical lift (section 7), kg.

        M_eff(x) = 2 m K U(q(x)) / U'(q(x))^2, equal to m / (dx/dq)^2.
        """
        q = self.q_of_x(x)
        U = self.potential.U(q)
        dU = self.potential.dU(q)
        return 2 * self.m * self.K * U / dU**2
