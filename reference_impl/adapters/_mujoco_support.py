"""Support of the MuJoCo adapter: the zero-force closed form, the polynomial damping law,
and small readers of MuJoCo's data (see `reference_impl.adapters.mujoco`)."""

from __future__ import annotations

import math

from scipy.optimize import brentq

from reference_impl.errors import HCVInputError

__all__ = ["restitution_zero_force_linear", "zeta_zero_force"]

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
