"""The universal damping law of Theorem 3 and its power-law form (section 9).

With zeta = C0 / (2 sqrt(K M)) the law reads C(q) = 2 zeta sqrt(m) U'(q) / sqrt(2 U(q)),
which contains neither K nor M; in the virtual time tau the contact is then the
linear oscillator M x'' + C0 x' + K x = 0, whose restitution is
e = exp(-pi zeta / sqrt(1 - zeta^2)) at every impact speed.
"""

from __future__ import annotations

import math

import numpy as np

from reference_impl.errors import HCVInputError
from reference_impl.theory.harmonic_map import HarmonicMap
from reference_impl.potentials._checks import finite
from reference_impl.potentials.power import PowerLaw

__all__ = [
    "UniversalDamping",
    "restitution_from_zeta",
    "zeta_from_restitution",
    "tsuji_coefficient",
]


def _check_zeta(zeta) -> float:
    z = finite("zeta", zeta, "damping")
    if z < 0:
        raise HCVInputError(f"damping ratio zeta must be >= 0, got {zeta!r}")
    return z


def restitution_from_zeta(zeta: float) -> float:
    """Coefficient of restitution e = exp(-pi zeta / sqrt(1 - zeta^2)); 0 for zeta >= 1.

    This is the end of contact at q = 0 (the theory's definition), where the
    damper may pull during the last part of the contact.
    """
    z = _check_zeta(zeta)
    if z >= 1.0:
        return 0.0
    return math.exp(-math.pi * z / math.sqrt(1.0 - z * z))


def zeta_from_restitution(e: float) -> float:
    """Damping ratio for a restitution 0 < e <= 1: zeta = -ln e / sqrt(pi^2 + ln^2 e)."""
    ev = finite("restitution", e, "damping")
    if not 0 < ev <= 1:
        raise HCVInputError(f"restitution must be in (0, 1], got {e!r}")
    le = math.log(ev)
    return -le / math.sqrt(math.pi**2 + le * le)


class UniversalDamping:
    """Position-dependent damping C(q) of Theorem 3 for one map (U, m, K, M).

    Parameters
    ----------
    hmap : HarmonicMap
        The regularisation (fixes U, m, K, M).
    C0 : float, optional
        Virtual damping constant (kg/s of virtual time). Give exactly one of
        ``C0`` and ``zeta``.
    zeta : float, optional
        Damping ratio zeta = C0 / (2 sqrt(K M)) (dimensionless, >= 0).
    """

    def __init__(self, hmap: HarmonicMap, *, C0: float | None = None, zeta: float | None = None):
        if (C0 is None) == (zeta is None):
            raise HCVInputError("give exactly one of C0 and zeta")
        self.hmap = hmap
        scale = 2.0 * math.sqrt(hmap.K * hmap.M)
        if zeta is None:
            c0 = finite("C0", C0, "damping")
            if c0 < 0:
                raise HCVInputError(f"C0 must be >= 0, got {C0!r}")
            self.C0, self.zeta = c0, c0 / scale
        else:
            self.zeta = _check_zeta(zeta)
            self.C0 = self.zeta * scale

    def C(self, q):
        """Physical damping coefficient C(q) = C0 sqrt(m/M) U'/sqrt(2 K U) (kg/s)."""
        h = self.hmap
        return self.C0 * math.sqrt(h.m / h.M) * h.dxdq(q)

    def C_star(self, x, C=None):
        """Transformed damping C*(x) = C(q) sqrt(M/m) dq/dx (section 8).

        Parameters
        ----------
        x : array_like
            Energy coordinates (> 0).
        C : callable, optional
            Another physical law q -> C(q) to transform instead of this one.
        """
        h = self.hmap
        q = h.q_of_x(x)
        c = self.C(q) if C is None else np.asarray(C(q), dtype=float)
        return c * math.sqrt(h.M / h.m) / h.dxdq(q)

    @property
    def restitution(self) -> float:
        """Restitution at the end of contact q = 0 (independent of impact speed)."""
        return restitution_from_zeta(self.zeta)


def tsuji_coefficient(potential: PowerLaw, m: float, zeta: float) -> tuple[float, float]:
    """Tsuji form of the universal law for a power law: C(q) = c q^((p-1)/2).

    Returns
    -------
    c : float
        Coefficient, c = 2 zeta sqrt(m k (p + 1) / 2), in kg s^-1 m^-(p-1)/2.
    exponent : float
        (p - 1) / 2; 1/4 for Hertz (p = 3/2), Tsuji et al. (1992).
    """
    if not isinstance(potential, PowerLaw):
        raise HCVInputError(f"the Tsuji coefficient is defined for PowerLaw, got {potential!r}")
    z = _check_zeta(zeta)
    c = 2.0 * z * math.sqrt(m * potential.k * (potential.p + 1.0) / 2.0)
    return c, (potential.p - 1.0) / 2.0
