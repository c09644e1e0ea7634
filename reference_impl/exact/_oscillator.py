"""The virtual damped oscillator of Theorem 3, in forms that stay accurate at every zeta.

In virtual time s (K = M = m, so Omega0 = 1) the contact is

    x'' + 2 zeta x' + x = 0,   x(0) = 0,   x'(0) = v0,

with x(s) = v0 exp(-zeta s) S(s), where S(s) = sin(wd s)/wd (zeta < 1, wd =
sqrt(1 - zeta^2)), s (zeta = 1), sinh(r s)/r (zeta > 1, r = sqrt(zeta^2 - 1)).
Written this way nothing cancels near zeta = 1: 1 - zeta^2 is formed as
(1 - zeta)(1 + zeta), sin(wd s)/wd and sinh(r s)/r keep full relative precision
however small wd or r is, and the overdamped case is evaluated as
exp(-s / (zeta + r)) (-expm1(-2 r s)) / (2 r) instead of the difference of two
exponentials (which cancels to 0 near s = 0 and made the old solver return
inf). The peak of x is at s_peak = atan2(wd, zeta)/wd, 1 or log1p(zeta - 1 + r)/r,
the zero-force instant (x'' = 0) at 2 s_peak, where -x'/v0 = exp(-2 zeta s_peak)
exactly (cos(wd s_peak) = zeta, sin(wd s_peak) = wd).
"""

from __future__ import annotations

import math

import numpy as np

from reference_impl.errors import HCVInputError

__all__ = ["VirtualOscillator", "ZETA_MAX", "S_END_MAX"]

# Largest damping ratio accepted: the suite checks the solver against the mpmath
# truth up to here; beyond it the contact is a creep whose zero-force time shrinks
# like log(zeta)/zeta and no DEM user meets it.
ZETA_MAX = 1.0e3
# Largest virtual time of the theory's end of contact (zeta just below 1, s_end =
# pi / sqrt(1 - zeta^2)): x falls to ~exp(-zeta s_end) there, and the quadrature
# nodes need x^2 (and q) to stay normal float64 numbers down to 1e-17 of the way
# from that end; exp(-300) ~ 5e-131 keeps x^2 > 1e-300.
S_END_MAX = 300.0


class VirtualOscillator:
    """The damped linear oscillator x'' + 2 zeta x' + x = 0, x(0) = 0, x'(0) = v0.

    Parameters
    ----------
    v0 : float
        Initial virtual velocity (equal to the impact speed, m/s, since M = m).
    zeta : float
        Damping ratio, 0 <= zeta <= ZETA_MAX.

    Attributes
    ----------
    wd : float
        Damped frequency sqrt(1 - zeta^2) (0 when zeta >= 1), per unit virtual time.
    r : float
        sqrt(zeta^2 - 1) when zeta > 1, else 0.
    s_peak, s_zero_force, s_end : float
        Virtual times of maximum compression, of zero total force (2 s_peak) and of
        the return to x = 0 (pi / wd; inf when zeta >= 1).
    """

    def __init__(self, v0: float, zeta: float):
        if not 0.0 <= zeta <= ZETA_MAX:
            raise HCVInputError(f"damping ratio zeta = {zeta!r} is outside [0, {ZETA_MAX:g}]")
        self.v0 = v0
        self.zeta = zeta
        self.wd = 0.0
        self.r = 0.0
        if zeta < 1.0:
            self.wd = math.sqrt((1.0 - zeta) * (1.0 + zeta))
            self.s_peak = math.atan2(self.wd, zeta) / self.wd
            self.s_end = math.pi / self.wd
            if self.s_end > S_END_MAX:
                z_lim = math.sqrt(1.0 - (math.pi / S_END_MAX) ** 2)
                raise HCVInputError(
                    f"damping ratio zeta = {zeta!r} is too close to 1: the theory's end of contact "
                    f"lies at virtual time pi/sqrt(1 - zeta^2) = {self.s_end:.4g} > {S_END_MAX:g}, "
                    f"beyond float64 range; supported: zeta <= {z_lim:.7f} or 1 <= zeta <= "
                    f"{ZETA_MAX:g}"
                )
        elif zeta == 1.0:
            self.s_peak = 1.0
            self.s_end = math.inf
        else:
            self.r = math.sqrt(zeta - 1.0) * math.sqrt(zeta + 1.0)
            # atanh(r/zeta)/r = log(zeta + r)/r, written with log1p for r -> 0.
            self.s_peak = math.log1p((zeta - 1.0) + self.r) / self.r
            self.s_end = math.inf
        # x'' = 0 at exactly twice the peak time (see module docstring).
        self.s_zero_force = 2.0 * self.s_peak

    @classmethod
    def _of(cls, v0: float, zeta: float, wd: float, s_peak: float, s_end: float):
        """The underdamped oscillator (0 <= zeta < 1) from wd, s_peak and s_end computed
        elsewhere by `__init__`'s formulas (the prepared call's compiled kernels), without
        repeating them: the same attributes."""
        osc = object.__new__(cls)
        osc.__dict__.update(
            {
                "v0": v0,
                "zeta": zeta,
                "wd": wd,
                "r": 0.0,
                "s_peak": s_peak,
                "s_end": s_end,
                "s_zero_force": 2.0 * s_peak,
            }
        )
        return osc

    @property
    def zero_force_stretch(self) -> float:
        """Virtual time from the zero-force instant to s_end (underdamped), cancellation-free:
        s_end - 2 s_peak = 2 atan2(zeta, wd) / wd."""
        return 2.0 * math.atan2(self.zeta, self.wd) / self.wd

    @property
    def restitution_zero_force(self) -> float:
        """-x'(2 s_peak) / v0 = exp(-2 zeta s_peak), for every zeta."""
        return math.exp(-2.0 * self.zeta * self.s_peak)

    def x(self, s):
        """Virtual displacement x(s) (m), vectorised."""
        z, v0 = self.zeta, self.v0
        s = np.asarray(s, dtype=float)
        if z < 1.0:
            return v0 * np.exp(-z * s) * (np.sin(self.wd * s) / self.wd)
        if z == 1.0:
            return v0 * s * np.exp(-s)
        r = self.r
        return v0 * np.exp(-s / (z + r)) * (-np.expm1(-2.0 * r * s)) / (2.0 * r)

    def x_from_end(self, d):
        """x at s = s_end - d, accurate for small d (underdamped only)."""
        return self.v0 * np.exp(-self.zeta * (self.s_end - d)) * (np.sin(self.wd * d) / self.wd)

    def dx(self, s):
        """Virtual velocity x'(s) (m/s), vectorised."""
        z, v0 = self.zeta, self.v0
        s = np.asarray(s, dtype=float)
        if z < 1.0:
            wd = self.wd
            return v0 * np.exp(-z * s) * (np.cos(wd * s) - z * (np.sin(wd * s) / wd))
        if z == 1.0:
            return v0 * (1.0 - s) * np.exp(-s)
        r = self.r
        a = 1.0 / (z + r)  # = z - r without cancellation
        e2 = np.exp(-2.0 * r * s)
        return v0 * np.exp(-a * s) * (-a * (-np.expm1(-2.0 * r * s)) + 2.0 * r * e2) / (2.0 * r)
