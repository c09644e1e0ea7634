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
from reference_impl.potentials._checks import finite
from reference_impl.potentials.power import PowerLaw
from reference_impl.theory.harmonic_map import HarmonicMap

__all__ = [
    "UniversalDamping",
    "restitution_from_zeta",
    "restitution_zero_force_from_zeta",
    "zeta_from_restitution",
    "RESTITUTION_ENDS",
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


RESTITUTION_ENDS = ("overlap", "zero-force")
# Largest zeta searched by the zero-force inverse (the solvers' ZETA_MAX).
_ZETA_SEARCH_MAX = 1000.0


def restitution_zero_force_from_zeta(zeta: float) -> float:
    """Restitution at the zero-force end of the universal law, exp(-2 zeta s_peak).

    s_peak is the virtual time of maximum compression: atan2(wd, zeta) / wd with
    wd = sqrt(1 - zeta^2) (zeta < 1), 1 (zeta = 1), ln(zeta + r) / r with
    r = sqrt(zeta^2 - 1) (zeta > 1). This is what a code that clips tension delivers
    (the contact ends where U' + C q' = 0, at twice s_peak), at every speed.
    """
    z = _check_zeta(zeta)
    if z == 0:
        return 1.0
    if z < 1:
        wd = math.sqrt((1.0 - z) * (1.0 + z))
        s_peak = math.atan2(wd, z) / wd
    elif z == 1:
        s_peak = 1.0
    else:
        r = math.sqrt((z - 1.0) * (z + 1.0))
        s_peak = math.log(z + r) / r
    return math.exp(-2.0 * z * s_peak)


def zeta_from_restitution(e: float, end: str = "overlap") -> float:
    """Damping ratio of the universal law for a restitution 0 < e <= 1 at the given end.

    Parameters
    ----------
    e : float
        Coefficient of restitution -v_out / v0 (dimensionless).
    end : {"overlap", "zero-force"}
        ``"overlap"`` (default): e is measured where q returns to 0 (the theory's end),
        zeta = -ln e / sqrt(pi^2 + ln^2 e). ``"zero-force"``: e is measured where the
        total force U' + C q' first vanishes (codes that clip tension: Kratos, MuJoCo,
        most DEM codes); inverted from `restitution_zero_force_from_zeta` to round-off.

    Returns
    -------
    float
        zeta (dimensionless, >= 0).
    """
    if end not in RESTITUTION_ENDS:
        raise HCVInputError(
            f"restitution end must be one of {', '.join(RESTITUTION_ENDS)}, got {end!r}"
        )
    ev = finite("restitution", e, "damping")
    if not 0 < ev <= 1:
        raise HCVInputError(f"restitution must be in (0, 1], got {e!r}")
    if end == "overlap":
        le = math.log(ev)
        return -le / math.sqrt(math.pi**2 + le * le)
    if ev == 1.0:
        return 0.0
    e_min = restitution_zero_force_from_zeta(_ZETA_SEARCH_MAX)
    if ev < e_min:
        raise HCVInputError(
            f"zero-force restitution {e!r} is below {e_min:.3g}, reached only for zeta > "
            f"{_ZETA_SEARCH_MAX:g}"
        )
    from scipy.optimize import brentq

    # e_zf(zeta) decreases monotonically from 1; brentq to a few ulps of zeta.
    return brentq(
        lambda z: restitution_zero_force_from_zeta(z) - ev,
        0.0,
        _ZETA_SEARCH_MAX,
        xtol=1e-300,
        rtol=4 * 2.0**-52,
        maxiter=500,
    )


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
