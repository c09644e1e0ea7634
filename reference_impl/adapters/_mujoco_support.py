"""Support of the MuJoCo adapter: the zero-force closed form, the polynomial damping law,
and small readers of MuJoCo's data (see `reference_impl.adapters.mujoco`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from reference_impl.errors import HCVInputError
from reference_impl.adapters.base import AdapterScene, ImplementedLaw

__all__ = ["PolynomialDamping", "restitution_zero_force_linear", "zeta_zero_force"]

# Largest damping ratio of the zero-force inversion (the solver's own bound on zeta).
_ZETA_MAX = 1000.0
# mj_warning index of a bad acceleration (mjWARN_BADQACC) when the enum is not exposed.
_WARN_BADQACC = 7


def restitution_zero_force_linear(zeta: float) -> float:
    """Restitution of a linear spring-dashpot at its zero-total-force end.

    e = exp(-2 zeta arccos(zeta) / sqrt(1 - zeta^2)) for zeta < 1 (the universal
    law's zero-force end, README), continued by arccosh for zeta > 1 and e^-2 at 1.
    """
    z = float(zeta)
    if z <= 0.0:
        return 1.0
    if abs(z - 1.0) < 1e-9:
        return math.exp(-2.0)
    if z < 1.0:
        return math.exp(-2.0 * z * math.acos(z) / math.sqrt(1.0 - z * z))
    return math.exp(-2.0 * z * math.acosh(z) / math.sqrt(z * z - 1.0))


def zeta_zero_force(e: float) -> float:
    """Damping ratio whose linear spring-dashpot rebounds with e at the zero-force end."""
    if not (0.0 < e <= 1.0):
        raise HCVInputError(f"restitution must be in (0, 1], got {e!r}")
    if e == 1.0:
        return 0.0
    lo_e = restitution_zero_force_linear(_ZETA_MAX)
    if e <= lo_e:
        raise HCVInputError(
            f"restitution {e!r} at the zero-force end needs a damping ratio above {_ZETA_MAX:g}"
        )
    return float(brentq(lambda z: restitution_zero_force_linear(z) - e, 0.0, _ZETA_MAX, xtol=1e-15))


@dataclass(frozen=True)
class PolynomialDamping:
    """Damping coefficient C(q) = sum_i c[i] q^i (kg/s, q in m): picklable, JSON-describable.

    Its JSON form is the ``polynomial`` damping law of the adapter protocol
    (``{"law": "polynomial", "c": [c0, c1, ...]}``).
    """

    c: tuple

    def __call__(self, q):
        q = np.asarray(q, dtype=float)
        out = np.zeros_like(q)
        for coef in reversed(self.c):  # Horner
            out = out * q + coef
        return out

    def to_json(self) -> dict:
        return {"law": "polynomial", "c": [float(x) for x in self.c]}


def _bench_runs(law: ImplementedLaw, scene: AdapterScene) -> str | None:
    """None when the suite's textbook Verlet (the dt_crit baseline) runs a polynomial law.

    Until the damping laws of issue 18 reach the bench, `law_trajectory` refuses any
    damping but `PowerDamping` and the dt_crit metric would then be failed for a reason
    that is ours, not MuJoCo's: the default-impedance variant declines until it runs.
    """
    from reference_impl.adapters.reference import law_trajectory

    try:
        law_trajectory(law, scene.v0, 1e-3 * scene.dt, 2)
    except TypeError:
        return (
            "default impedance: its law (sum of powers, polynomial damping) is declared, but "
            "this suite's textbook Verlet cannot run polynomial damping yet (issue 18)"
        )
    return None


def _diag(data):
    """efc_diagA (MuJoCo 4) or efc_diagApprox (3.x)."""
    for name in ("efc_diagA", "efc_diagApprox"):
        if hasattr(data, name):
            return getattr(data, name)
    raise HCVInputError("this MuJoCo has neither efc_diagA nor efc_diagApprox")


def _badqacc_index(mj) -> int:
    enum = getattr(mj, "mjtWarning", None)
    bit = getattr(enum, "mjWARN_BADQACC", None) if enum is not None else None
    return int(bit) if bit is not None else _WARN_BADQACC
