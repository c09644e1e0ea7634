"""Where an expression's U rises from 0: the interval its turning point is searched on.

The turning point must lie on the connected interval where U increases from
U(0) = 0 (assumptions 3-4 of section 3; issue 22): a bracket doubled blindly can
jump past a pole or a maximum and find a root on another branch (tan(q) at
4.5 J: 4.49 m instead of atan(4.5) = 1.35 m), or refuse a valid input because U
is lower past the maximum than before it (1 - cos(q) at 1.98 J). `rising_top`
walks U and U' upward from an overlap on the first branch and returns an
overlap, below any such point, where U already reaches the energy.
"""

from __future__ import annotations

import math

import numpy as np

from reference_impl.errors import NonMonotoneError, NoTurningPointError
from reference_impl.potentials._expr_parse import _short

__all__ = ["on_first_branch", "rising_top"]

# Grid points per doubling of q in the walk that finds where U stops rising
# (`rising_top`), and bisection steps locating that point (float64: ~1100 at most
# from a doubling; 200 reach a few ulps of q from any bracket within 2**100).
_WALK_POINTS = 16
# Relative distance of U from its leading term c q^n within which an overlap is
# taken to lie on the branch of U that starts at 0 (where the walk begins).
_LEADING_RTOL = 0.01
_BISECT_STEPS = 200
# Doublings of q allowed (1100 span float64), and the smallest positive float64.
_MAX_STEPS = 1100
_TINY_Q = 5e-324


def rising_top(pot, energy: float, q0: float) -> float:
    """An overlap q_top with U(q_top) >= energy and U rising on [q0, q_top].

    The turning point is searched only on the connected interval where U
    increases from 0 (issue 22): U is walked upward in doublings of q, each
    checked on a grid of _WALK_POINTS (U finite, not decreasing, U' >= 0);
    at the first grid point that fails, the interval before it is bisected to
    where U stops rising (a pole, a maximum, the end of the domain), and the
    energy must be reached before that point. Cached: a lower energy reuses
    the top of a higher one.
    """
    cached = getattr(pot, "_top_cache", None)
    if cached is not None and energy <= cached[0] and q0 < cached[1]:
        return cached[1]
    a = on_first_branch(pot, q0)
    with np.errstate(all="ignore"):
        ua = float(pot._U(np.array([a]))[0])
    for _ in range(_MAX_STEPS):
        b = 2.0 * a
        if not math.isfinite(b):
            raise NoTurningPointError(
                f"Expression: U = {_short(pot.source)} stays below the energy {energy:.6g} J "
                f"for every float64 overlap (U = {ua:.6g} J at q = {a:.3g} m): no turning "
                "point (assumption 4 of section 3); lower the impact speed"
            )
        grid = np.linspace(a, b, _WALK_POINTS + 1)[1:]
        with np.errstate(all="ignore"):
            ug = pot._U(grid)
            fg = pot._dU(grid)
        prev = np.concatenate(([ua], ug[:-1]))
        ok = np.isfinite(ug) & np.isfinite(fg) & (ug >= prev) & (fg >= 0)
        stop = ~ok | (ug >= energy)
        # Equal non-zero values below the energy: U levels off (equal zeros are an
        # underflow of values below it, not a plateau).
        flat = ok & (ug == prev) & (ug != 0) & (ug < energy)
        if np.any(flat) and (not np.any(stop) or np.argmax(flat) < np.argmax(stop)):
            k = int(np.argmax(flat))
            q_prev = float(grid[k - 1]) if k else a
            raise NoTurningPointError(
                f"Expression: U = {_short(pot.source)} levels off at {ug[k]:.6g} J (equal at "
                f"q = {q_prev:.6g} m and {grid[k]:.6g} m) below the energy {energy:.6g} J: no "
                "turning point (assumption 4 of section 3); lower the impact speed"
            )
        if np.any(stop):
            k = int(np.argmax(stop))
            if ok[k]:
                top = float(grid[k])
            else:
                top = _last_rising(
                    pot,
                    float(prev[k]),
                    float(grid[k - 1]) if k else a,
                    float(grid[k]),
                    energy,
                    (float(grid[k]), float(ug[k]), float(fg[k])),
                )
            pot._top_cache = (energy, top)
            return top
        a, ua = b, float(ug[-1])
    raise AssertionError("unreachable: 1100 doublings overflow float64")


def on_first_branch(pot, q: float) -> float:
    """q, or a smaller overlap where U is within _LEADING_RTOL of its leading term
    c q^n, which holds near 0 (decided exactly at construction): the bracket's
    start from the leading-term guess can lie past a pole (tan(q) at 4.5 J: the
    guess 2.25 m is on the next branch), and the walk must start on the first."""
    c, n = pot.leading_coefficient, pot.leading_exponent
    for _ in range(_MAX_STEPS):
        with np.errstate(all="ignore"):
            lead = c * q**n
            u = float(pot._U(np.array([q]))[0])
        if not (math.isfinite(lead) and lead > 0) or abs(u / lead - 1.0) <= _LEADING_RTOL:
            return q
        if q <= _TINY_Q:
            return q
        q = max(q / 4.0, _TINY_Q)
    return q


def _last_rising(pot, ua: float, a: float, b: float, energy: float, bad) -> float:
    """Bisect [a, b] (U rising at a, below the energy; not at b) for an overlap where
    U reaches the energy while still rising, else refuse naming where it stops
    (``bad``: (q, U, U') at b, the witness named unless bisection finds a closer one
    where U' < 0 or U is not finite)."""
    qb, ub, fb = bad
    for _ in range(_BISECT_STEPS):
        mid = 0.5 * (a + b)
        if not a < mid < b:
            break
        with np.errstate(all="ignore"):
            um = float(pot._U(np.array([mid]))[0])
            fm = float(pot._dU(np.array([mid]))[0])
        if math.isfinite(um) and math.isfinite(fm) and um >= ua and fm >= 0:
            if um >= energy:
                return mid
            a, ua = mid, um
        else:
            b = mid
            if not (math.isfinite(um) and math.isfinite(fm)) or fm < 0:
                qb, ub, fb = mid, um, fm
    src, tail = _short(pot.source), "lower the impact speed or fix U"
    reached = f"U = {src} rises from 0 only to {ua:.6g} J (at q = {a:.6g} m), below the energy {energy:.6g} J"
    if math.isfinite(fb) and math.isfinite(ub):
        where = (
            f"U'(q) = {fb:.6g} N at q = {qb:.6g} m is not > 0"
            if fb < 0
            else f"U decreases after q = {a:.6g} m (U = {ub:.6g} J at q = {qb:.6g} m)"
        )
        raise NonMonotoneError(
            f"Expression: {where}: {reached}, and turns down there (assumption 3 of "
            f"section 3); {tail}"
        )
    raise NoTurningPointError(
        f"Expression: U(q) = {ub:.6g} J is not a finite number at q = {qb:.6g} m: {reached} "
        f"(a pole or the end of its domain): no turning point (assumption 4 of section 3); {tail}"
    )
