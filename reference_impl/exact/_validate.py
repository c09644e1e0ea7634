"""What every exact solver checks of a potential before it integrates (validate once, at the top).

Shared by the universal-law quadrature (`reference_impl.exact.solve`) and the general-law
solver (`reference_impl.exact.general_law`), so that both refuse the same inputs.
"""

from __future__ import annotations

import math
import weakref

from reference_impl.errors import HCVInputError
from reference_impl.potentials.base import Potential

__all__ = ["N_MAX"]

# Largest leading exponent n (U ~ q^n) accepted: beta = 2/n - 1 >= -0.905. Above it
# the endpoint singularity s^beta is so close to non-integrable that the float rules
# lost digits (p = 50: 8th digit, p = 1000: 5th, issue 12).
N_MAX = 21.0


def _check_exponent(pot: Potential) -> float:
    """The leading exponent n, refused above N_MAX (see there)."""
    n = float(pot.leading_exponent)
    if not (math.isfinite(n) and 0.0 < n <= N_MAX):
        raise HCVInputError(
            f"leading exponent n = {n:.6g} of U ~ q^n is outside (0, {N_MAX:g}] (power law "
            f"p = n - 1 <= {N_MAX - 1:g}): dq/dx ~ s^(2/n - 1) is then too close to "
            "non-integrable for the float quadrature to keep 1e-13"
        )
    return n


_VALIDATED: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
# Turning points kept per potential (exact values of earlier energies; a repeated speed
# skips the inverse: ~6 us for a cap in closed form, ~1 ms for a sum found numerically). Bounded: a sweep of distinct speeds
# must not grow it without limit.
_TOPS_KEPT = 64


def _validated_below(pot: Potential, E: float) -> bool:
    """True when an energy >= E was validated for ``pot`` already (`_validated_top`): its
    (0, q_max(E)] is checked, and only the turning point itself is left to compute."""
    try:
        e_c, _ = _VALIDATED[pot]
    except (KeyError, TypeError):
        return False
    return E <= e_c


def _validated_top(pot: Potential, E: float) -> float:
    """The turning point q_max(E) (m), with U' > 0 checked on (0, q_max] (assumption 3).

    The check (a grid of ~2600 points) dominated the cost of one impact; the
    largest validated energy is kept per potential object, and a lower energy
    skips the check: its (0, q_max(E)] lies inside the interval already checked.
    Potentials are immutable after construction, so the cache cannot go stale.

    The value returned is always this energy's own turning point, never a higher
    energy's: the solvers use it as a bracket and as the scale of their error control,
    so a cached top of a higher energy changed their numbers with the calls made
    before (general law: error_time 1.2e-15 fresh vs 8.0e-13 after a faster impact).
    The cache only skips work (the check, or the inverse of an energy seen before);
    no computed value depends on it.
    """
    try:
        e_c, tops = _VALIDATED[pot]
    except (KeyError, TypeError):
        e_c, tops = None, None
    if e_c is not None and E <= e_c:
        q = tops.get(E)
        if q is None:
            # Checked already (on a larger interval); the same _inverse as the checked call.
            q = pot.turning_point(E, check=False)
            if len(tops) >= _TOPS_KEPT:
                tops.pop(next(iter(tops), None), None)  # oldest; another thread may have popped it
            tops[E] = q
        return q
    q = pot.turning_point(E)
    try:
        _VALIDATED[pot] = (E, {E: q})
    except TypeError:
        pass
    return q
