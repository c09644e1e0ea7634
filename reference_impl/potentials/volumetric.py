"""The alpha-regularised volumetric contact model of section 10.

U(delta) = Kn / (alpha + 1) * V_c(delta)^(alpha + 1), where V_c is the exact
overlap volume of the body with a flat wall and S_n = dV_c/d delta the exact
cross-section. For a cap of an ellipsoid with semi-axes (a, b, c) cut normal to
the a-axis,

    S_n = c0 (2 a delta - delta^2),   V_c = c0 (a delta^2 - delta^3 / 3),

with c0 = pi b c / a^2; the sphere is the case a = b = c = R. Both formulas are
exact for 0 <= delta <= 2a; outside that interval the body has left the wall
or passed through it, and the potential raises `DomainError`.
"""

from __future__ import annotations

import math
import sys
from typing import Any

import numpy as np

from reference_impl.potentials._cap_inverse import CapInverse
from reference_impl.potentials._checks import positive
from reference_impl.potentials._families import register_family
from reference_impl.potentials._terms import cap_row
from reference_impl.potentials.base import Potential, is_mp

__all__ = ["Ellipsoid", "Sphere"]


class _VolumetricCap(Potential):
    """Cap of a quadric of revolution-like shape: shared by Ellipsoid and Sphere."""

    def __init__(self, a: float, bc: float, Kn: float, alpha: float, owner: str):
        self._a = a
        self._bc = bc  # product b * c of the two transverse semi-axes (m^2)
        self.Kn = positive("Kn", Kn, owner)
        self.alpha = positive("alpha", alpha, owner)
        self.q_sup = 2.0 * a
        self.q_scale = a
        # V_c ~ delta^2 near contact onset, so U ~ delta^(2 (alpha + 1)).
        self.leading_exponent = 2.0 * (self.alpha + 1.0)
        # V_c = (pi bc / a^2)(a delta^2 - delta^3 / 3) ~ (pi bc / a) delta^2.
        self.leading_coefficient = (
            self.Kn / (self.alpha + 1.0) * (math.pi * bc / a) ** (self.alpha + 1.0)
        )
        # The closed-form inverse of U, for the classes whose law is the cap's: those that
        # opt in to its term table (a subclass may change the law, as for the table).
        tabled = type(self).__dict__.get("_term_rows") is _VolumetricCap._term_rows
        self._closed_inverse = CapInverse(self.Kn, self.alpha, a, bc) if tabled else None
        self._u_sup = None  # U(2a), kept on first use (`_energy_sup`)

    def _term_rows(self):
        # Shared by Ellipsoid and Sphere, each of which opts in below (a table counts only
        # from the class's own body: `reference_impl.potentials._terms`).
        return [cap_row(self.Kn, self.alpha, self._a, math.pi * self._bc / self._a**2)]

    def _inverse(self, u: np.ndarray) -> np.ndarray:
        # Closed form (`_cap_inverse`): ~2 us for the one energy of a turning point, where
        # the generic root finder took ~190 us; the energies it does not take (extreme
        # scales, the far pole's round-off, an energy above U(2a)) go to that root finder,
        # which also raises the refusal.
        if self._closed_inverse is None:
            return self._numeric_inverse(u)
        if u.shape == (1,):
            q = self._closed_inverse.one(float(u[0]))
            return np.array([q]) if q == q else self._numeric_inverse(u)
        q = self._closed_inverse.many(u)
        rest = np.isnan(q)
        if np.any(rest):
            q[rest] = self._numeric_inverse(u[rest])
        return q

    def _energy_sup(self) -> float:
        # Every turning point compares its energy with U(2a): ~13 us of numpy on one
        # element, which was as long as the rest of the turning point; fixed at construction.
        if self._u_sup is None:
            self._u_sup = super()._energy_sup()
        return self._u_sup

    def _c0(self, q):
        return self._ns(q).pi * self._bc / self._a**2

    def volume(self, q):
        """Exact overlap volume V_c(delta) in m^3 (no domain check)."""
        a = self._a
        return self._c0(q) * (a * q**2 - q**3 / 3)

    def area(self, q):
        """Exact cross-sectional contact area S_n(delta) = dV_c/d delta in m^2."""
        return self._c0(q) * (2 * self._a * q - q**2)

    def _U(self, q):
        # Kn V^(alpha+1) / (alpha+1), not (Kn / (alpha+1)) V^...: the quotient would be
        # rounded to float64 before an mpmath V multiplies it, and the 30-digit path
        # would then carry a 1e-16 relative error (found by reports/repro, sec10).
        # In mpmath alpha + 1 is formed at working precision: the float sum rounds it
        # (alpha = 0.0134... gains ~1e-17), and U would then not be the integral of _dU
        # (which uses alpha) by ~1e-16 |ln V|: the 30-digit truth carried 5e-15 at
        # V ~ 1e-20 (found by review of the cap nodes).
        ap1 = self.alpha + 1 if not is_mp(q) else sys.modules["mpmath"].mpf(self.alpha) + 1
        return self.Kn * self.volume(q) ** ap1 / ap1

    def _dU(self, q):
        return self.Kn * self.volume(q) ** self.alpha * self.area(q)

    def _d2U(self, q):
        # U'' = Kn V^alpha (alpha S^2 / V + S'); S^2 / V is written in the form
        # c0 (2a - delta)^2 / (a - delta/3), which stays finite at delta = 0.
        a = self._a
        c0 = self._c0(q)
        s2_over_v = c0 * (2 * a - q) ** 2 / (a - q / 3)
        dS = c0 * (2 * a - 2 * q)
        return self.Kn * self.volume(q) ** self.alpha * (self.alpha * s2_over_v + dS)


@register_family
class Ellipsoid(_VolumetricCap):
    """Ellipsoid with semi-axes (a, b, c) hitting a flat wall along its a-axis.

    Parameters
    ----------
    a, b, c : float
        Semi-axes in metres (> 0); the impact is along ``a``.
    Kn : float
        Volumetric stiffness parameter (J / m^(3 (alpha + 1))); the paper writes "Pa".
    alpha : float
        Regularisation exponent (> 0); 0.5 gives U ~ delta^3 near onset.
    """

    family = "ellipsoid"
    scene_keys = (("a", "b", "c", "Kn"), ("alpha",))
    label = "volumetric ellipsoid cap U = Kn V^(alpha+1) / (alpha+1) (a, b, c in m)"
    _term_rows = _VolumetricCap._term_rows

    def __init__(self, a: float, b: float, c: float, Kn: float, alpha: float = 0.5):
        self.a = positive("a", a, "Ellipsoid")
        self.b = positive("b", b, "Ellipsoid")
        self.c = positive("c", c, "Ellipsoid")
        super().__init__(self.a, self.b * self.c, Kn, alpha, "Ellipsoid")

    def params(self) -> dict[str, Any]:
        return {"a": self.a, "b": self.b, "c": self.c, "Kn": self.Kn, "alpha": self.alpha}

    def __repr__(self) -> str:
        return f"Ellipsoid(a={self.a!r}, b={self.b!r}, c={self.c!r}, Kn={self.Kn!r}, alpha={self.alpha!r})"


@register_family
class Sphere(_VolumetricCap):
    """Sphere of radius R hitting a flat wall (spherical-cap overlap volume).

    Parameters
    ----------
    R : float
        Radius in metres (> 0).
    Kn : float
        Volumetric stiffness parameter, as for `Ellipsoid`.
    alpha : float
        Regularisation exponent (> 0).
    """

    family = "sphere"
    scene_keys = (("R", "Kn"), ("alpha",))
    label = "volumetric sphere cap U = Kn V^(alpha+1) / (alpha+1) (R in m; not a Hertz sphere)"
    _term_rows = _VolumetricCap._term_rows

    def __init__(self, R: float, Kn: float, alpha: float = 0.5):
        self.R = positive("R", R, "Sphere")
        super().__init__(self.R, self.R * self.R, Kn, alpha, "Sphere")

    def params(self) -> dict[str, Any]:
        return {"R": self.R, "Kn": self.Kn, "alpha": self.alpha}

    def __repr__(self) -> str:
        return f"Sphere(R={self.R!r}, Kn={self.Kn!r}, alpha={self.alpha!r})"
