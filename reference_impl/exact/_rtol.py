"""The accuracy argument ``rtol`` of the exact solvers (issue 38, goal 2).

``rtol=None`` (the default) is the solvers' full accuracy, bit for bit what they return
without the argument. A number in (0, `RTOL_MAX`] asks for a relative error bound of at
most ``rtol`` on each reported time, and lets the solver spend less to reach it:

* the universal law on a power law (`_power_kernel.power_impact`): a smaller pair of
  Gauss-Jacobi rules (`POWER_RUNGS`), the result kept only when the pair agrees to
  ``rtol`` on every branch and the bound of each time (the pair's difference plus
  round-off, as at full accuracy) is at most ``rtol`` of it; otherwise the next larger
  pair, up to the full-accuracy one;
* a general law on the Taylor kernel (`_general_taylor`; on a single cap,
  `_taylor_cap`): a longer step, the truncation
  per step ``taylor_tol(rtol)`` instead of `_general_taylor.TOL`; the bound is the same
  sum of the steps' truncation estimates as at full accuracy;
* the universal law on a single cap (a sphere or an ellipsoid, `_one_call`): with
  ``rtol >= 1e-12`` the fused Gauss-Jacobi pair is kept where its reported bound is within
  ``rtol / 2`` (the other half is left for the conditioning term `solve_impact` adds),
  instead of falling to the general path where the pair disagrees at 1e-14.

Every other path (sums and the other families, the split and tanh-sinh quadratures, the
overdamped tail, the linear closed form, the GBS kernel) runs at full accuracy whatever
``rtol`` asks: its bound is smaller, and still reported. An ``rtol`` below what full
accuracy reaches returns the full-accuracy result and its bound (a tolerance is a
request, the bound is the answer).
"""

from __future__ import annotations

import math

from reference_impl.errors import HCVInputError
from reference_impl.potentials._checks import is_real_number

__all__ = ["POWER_RUNGS", "RTOL_MAX", "checked_rtol", "power_rungs", "taylor_tol"]

# Largest rtol accepted: beyond 10 % a "bound" is no longer a small correction to the
# time it bounds, and the smallest rule pair already reaches ~1e-3.
RTOL_MAX = 0.1

# Gauss-Jacobi pairs (coarse, fine) tried for a power law, with the smallest rtol each is
# chosen for: about twice the largest bound the pair reported (relative, either time)
# over 300 random impacts each at v0 in [0.01, 10] m/s, zeta in [0, 0.9), for p = 1.5,
# 2 and 3 (measured 2026-11-29: (3, 4) 7.1e-4, (4, 6) 1.1e-4, (6, 8) 2.4e-6, (8, 10)
# 7.4e-8, (10, 14) 2.2e-9, (12, 16) 6.4e-11; the true error of the fine rule was at most
# 0.4 of the bound in every case). An impact a pair refuses climbs to the next; after the
# last comes the full-accuracy pair `_branches._GJ_SIZES`.
POWER_RUNGS = (
    ((3, 4), 1.5e-3),
    ((4, 6), 2.5e-4),
    ((6, 8), 5e-6),
    ((8, 10), 1.5e-7),
    ((10, 14), 5e-9),
    ((12, 16), 1.5e-10),
)

# Share of rtol given to the Taylor kernel's truncation per step: the bound reported is
# `general_law.ERROR_SAFETY` (10) times the sum of the per-step estimates over at most
# `_general_taylor.MAX_STEPS` (24) steps, in units of the scaled time (~1/3 of the
# contact time for Hertz), so 1/1000 keeps the bound below rtol of the contact time
# with a margin of ~1.4 for the longest contact. Measured (2026-11-29, Hertz with a linear
# dashpot and Hunt-Crossley, 100 speeds 0.01-10 m/s): bounds 3-4e-6 at rtol 1e-4, 3-5e-10
# at 1e-8, in 0.55 and 0.7 of full accuracy's steps.
_TAYLOR_SHARE = 1e-3


def checked_rtol(rtol, call: str = "solve"):
    """``rtol`` as a float, or None for full accuracy.

    Parameters
    ----------
    rtol : float or None
        Relative error bound asked of each reported time (dimensionless).
    call : str
        The caller's name, for the message.

    Raises
    ------
    HCVInputError
        ``rtol`` not a real number in (0, RTOL_MAX] (one line naming it).
    """
    if rtol is None:
        return None
    if type(rtol) is float and 0.0 < rtol <= RTOL_MAX:  # the common case, without the checks
        return rtol
    # A number, not a string or a bool that float() would take.
    r = float(rtol) if is_real_number(rtol) else math.nan
    if not (0.0 < r <= RTOL_MAX):
        raise HCVInputError(
            f"{call}: rtol = {rtol!r} is not a relative tolerance in (0, {RTOL_MAX:g}] "
            "(None: full accuracy)"
        )
    return r


def power_rungs(rtol: float) -> tuple[tuple[int, int], ...]:
    """The Gauss-Jacobi pairs to try, in order, for ``rtol`` (the first chosen for it, then
    every larger one of `POWER_RUNGS`); empty when only full accuracy reaches it."""
    for i, (_, smallest) in enumerate(POWER_RUNGS):
        if smallest <= rtol:
            return tuple(sizes for sizes, _ in POWER_RUNGS[i:])
    return ()


def taylor_tol(rtol: float, tol_full: float) -> float:
    """The Taylor kernel's truncation per step for ``rtol``, never below its full-accuracy
    ``tol_full`` (`_general_taylor.TOL`)."""
    return max(tol_full, _TAYLOR_SHARE * rtol)
