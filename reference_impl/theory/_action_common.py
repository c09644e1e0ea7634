"""Input checks and constants shared by the two routes of `reference_impl.theory.action`.

The float64 route (`action`) and the mpmath route (`action_mp`) both import them from
here, so that neither imports the other (the mpmath route loads on first use).
"""

from __future__ import annotations

import math
import sys
from numbers import Real

from reference_impl.errors import HCVInputError
from reference_impl.potentials.base import Potential
from reference_impl.potentials.power import PowerLaw

# Split point of [0, q_max] as a fraction of q_max: below it E - U >= E - U(q_max/2)
# is bounded away from 0; above it the turning-point substitution applies.
_SPLIT = 0.5
# Guard digits added to the requested dps for every mpmath computation (`action_mp`,
# `action_closed`), so that the returned value is correct to the requested digits.
_GUARD_DPS = 10


def _check_pot(pot) -> None:
    if not isinstance(pot, Potential):
        raise HCVInputError(f"potential must be a Potential instance, got {pot!r}")


def _check_positive(name: str, value, unit: str) -> None:
    """Raise unless ``value`` is a finite real number > 0 (float, int or mpf)."""
    # mpmath is looked up only when loaded: no mpmath number exists before that.
    mpmath = sys.modules.get("mpmath")
    mp = mpmath is not None and isinstance(value, mpmath.mpf)
    ok_type = (isinstance(value, Real) or mp) and not isinstance(value, bool)
    if not ok_type:
        raise HCVInputError(f"{name} must be a real number in {unit}, got {value!r}")
    finite = mpmath.isfinite(value) if mp else math.isfinite(value)
    if not finite or not value > 0:
        raise HCVInputError(f"{name} must be finite and > 0 ({unit}), got {value!r}")


def _check_dps(dps) -> int:
    if isinstance(dps, bool) or not isinstance(dps, int) or dps < 5:
        raise HCVInputError(f"dps (decimal digits) must be an integer >= 5, got {dps!r}")
    return dps


def _check_all(pot, m, E) -> None:
    _check_pot(pot)
    _check_positive("mass m", m, "kg")
    _check_positive("energy E", E, "J")


def _check_powerlaw(pot) -> None:
    if not isinstance(pot, PowerLaw):
        raise HCVInputError(
            f"the closed forms hold for a PowerLaw potential only, got {pot!r}; "
            "use the quadrature routes (action, period, ...) for other potentials"
        )
