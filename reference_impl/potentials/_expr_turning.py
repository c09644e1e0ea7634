"""Where an expression's U reaches an energy: its inverse (turning points) and U' > 0.

The base class brackets the root of U(q) = u from ``q_scale`` upwards, which presumes
U monotone and finite everywhere; a formula may be increasing, or defined, only up to
some overlap. `rising_inverse` climbs from below the root instead and stops with a message
naming where U decreases, levels off or stops being a finite number; `check_rising`
re-decides each float failure of U' > 0 at raised precision. Both serve
`reference_impl.potentials.expression.Expression` (``pot`` below), whose exact facts
at contact (U(0) = 0, U ~ c q^n with c > 0) were decided at construction.
"""

from __future__ import annotations

import math

import mpmath
import numpy as np
from scipy.optimize import elementwise

from reference_impl.errors import NonMonotoneError, NoTurningPointError
from reference_impl.potentials._expr_parse import _short
from reference_impl.potentials._near_zero import mp_accurate
from reference_impl.potentials._rising import on_first_branch, rising_top

__all__ = ["check_rising", "rising_inverse"]

# Bracket steps of the inverse: 1100 doublings span float64.
_MAX_BRACKET_STEPS = 1100
# Smallest overlap (m) the downward bracket search tries (the smallest positive
# float64): U above the energy even there means U does not rise from U(0) = 0.
_TINY_Q = 5e-324
# Root tolerance of the inverse of U: a few ulps of q, as in the base class.
_INVERSE_XRTOL = 4.0 * np.finfo(float).eps
# Grid that locates where U' <= 0 once U was seen to decrease: log points
# resolve q -> 0, linear ones the rest (the sizes of Potential.check_monotone).
_SCAN_LOG_POINTS = 600
_SCAN_LIN_POINTS = 2000


def check_rising(pot, q_max: float) -> None:
    """U' > 0 on a dense grid of (0, q_max], each float failure re-decided at raised precision.

    U(0) = 0 and U ~ c q^n with c > 0 were decided exactly at construction.
    A grid point where the float64 U' is not > 0 (an underflow, as for
    q**32 at 1e-12 m) counts as a violation only if the mpmath value, at a
    precision raised until it settles, confirms it.
    """
    grid = q_max * np.concatenate(
        [np.logspace(-12, 0, _SCAN_LOG_POINTS), np.linspace(0, 1, _SCAN_LIN_POINTS)[1:]]
    )
    grid = np.unique(grid[grid > 0])
    with np.errstate(all="ignore"):
        f = pot._dU(grid)
    for i in np.flatnonzero(~(np.isfinite(f) & (f > 0))):
        ref = mp_accurate(pot._mp_funcs[1], float(grid[i]), pot.leading_exponent)
        if not (mpmath.isfinite(ref) and ref > 0):
            shown = mpmath.nstr(ref, 6) if mpmath.isfinite(ref) else f"{f[i]:.6g}"
            raise NonMonotoneError(
                f"U'(q) = {shown} N at q = {grid[i]:.6g} m is not > 0: the potential is "
                f"not monotone on (0, q_max = {q_max:.6g} m] (assumption 3 of section 3)"
            )


def rising_inverse(pot, u: np.ndarray) -> np.ndarray:
    """Overlap q with U(q) = u: a checked geometric bracket, then Chandrupatla.

    The base class brackets from ``q_scale`` upwards, which presumes U is
    monotone and finite everywhere. A formula may be increasing or defined
    only up to some overlap, so this bracket climbs from below the root and
    stops with a message naming where U decreases, levels off or stops
    being a finite number.
    """
    u = np.asarray(u, dtype=float)
    out = np.zeros_like(u)
    pos = u > 0
    if not np.any(pos):
        return out
    target = u[pos]
    lo, hi = _bracket(pot, target)
    res = elementwise.find_root(
        lambda q, t: pot._U(q) - t,
        (lo, hi),
        args=(target,),
        tolerances=dict(xatol=0.0, xrtol=_INVERSE_XRTOL, fatol=0.0, frtol=0.0),
    )
    out[pos] = np.where(pot._U(hi) == target, hi, res.x)
    return out


def _bracket(pot, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi) with U(lo) < t <= U(hi), U increasing at the doubling points.

    The search starts at half the leading-term estimate (t / c)^(1/n), which
    is within a small factor of the root for small energies at any scale
    (1e300 q^2 at t = 1e-300 has its root at 1e-300 m). U(lo) = 0 is an
    accepted lower end: U > 0 near 0 was decided exactly (c > 0) at
    construction, so a zero is an underflow of a value below t.
    """
    with np.errstate(all="ignore"):
        guess = np.exp((np.log(t) - math.log(pot.leading_coefficient)) / pot.leading_exponent)
    guess = np.where(np.isfinite(guess) & (guess > 0), guess, pot.q_scale)
    lo = np.maximum(0.5 * guess, _TINY_Q)
    # Start on the branch of U that rises from 0 (the guess may lie past a pole).
    lo = np.minimum(lo, on_first_branch(pot, float(lo.max())))
    for _ in range(_MAX_BRACKET_STEPS):
        u_lo = pot._U(lo)
        bad = ~(u_lo < t)
        if not np.any(bad):
            break
        lo = np.where(bad, np.maximum(lo / 4, _TINY_Q), lo)
        if np.any(bad & (lo <= _TINY_Q) & ~(pot._U(lo) < t)):
            i = int(np.argmax(bad & (lo <= _TINY_Q)))
            raise NonMonotoneError(
                f"Expression: U(q) >= {t[i]:.6g} J already at q = {lo[i]:.3g} m, but U must "
                f"rise from U(0) = 0 (assumption 3 of section 3); check U = {_short(pot.source)}"
            )
    top = rising_top(pot, float(t.max()), float(lo.max()))
    hi, u_hi = lo.copy(), u_lo
    for _ in range(_MAX_BRACKET_STEPS):
        need = u_hi < t
        if not np.any(need):
            return lo, hi
        # Doubling is capped at `top`: past it U may have a pole or turn down, and
        # a root there belongs to another branch (tan(q) at 4.49 m for 4.5 J).
        with np.errstate(over="ignore"):
            new = np.where(need, np.minimum(2 * hi, top), hi)
        u_new = pot._U(new)
        _check_step(pot, need, hi, u_hi, new, u_new, t)
        lo, hi, u_hi = np.where(need, hi, lo), new, u_new
    raise AssertionError("unreachable: 1100 doublings overflow float64")


def _check_step(pot, need, q0, u0, q1, u1, t) -> None:
    """Raise when U, stepping from q0 to q1 = 2 q0 while below the energy t, misbehaves."""
    src = _short(pot.source)
    tail = "no turning point (assumption 4 of section 3); lower the impact speed"
    endless = need & ~np.isfinite(q1)
    if np.any(endless):
        i = int(np.argmax(endless))
        raise NoTurningPointError(
            f"Expression: U = {src} stays below the energy {t[i]:.6g} J for every float64 "
            f"overlap (U = {u0[i]:.6g} J at q = {q0[i]:.3g} m): {tail}"
        )
    broken = need & ~np.isfinite(u1)
    if np.any(broken):
        i = int(np.argmax(broken))
        raise NoTurningPointError(
            f"Expression: U(q) = {u1[i]:.6g} J is not a finite number at q = {q1[i]:.6g} m, "
            f"reached before U = {src} gets to the energy {t[i]:.6g} J: {tail}"
        )
    if np.any(need & (u1 < u0)):
        i = int(np.argmax(need & (u1 < u0)))
        raise _not_monotone(pot, q1[i], t[i])
    # Equal zeros are an underflow of two values below t, not a plateau.
    flat = need & (u1 == u0) & (u0 != 0)
    if np.any(flat):
        i = int(np.argmax(flat))
        raise NoTurningPointError(
            f"Expression: U = {src} levels off at {u0[i]:.6g} J (equal at q = {q0[i]:.6g} m "
            f"and {q1[i]:.6g} m) below the energy {t[i]:.6g} J: {tail}"
        )


def _not_monotone(pot, q_end: float, energy: float) -> NonMonotoneError:
    """The error for U decreasing on (0, q_end], naming the first q with U' <= 0."""
    grid = q_end * np.concatenate(
        [np.logspace(-12, 0, _SCAN_LOG_POINTS), np.linspace(0, 1, _SCAN_LIN_POINTS)[1:]]
    )
    grid = np.unique(grid)
    f = pot._dU(grid)
    bad = ~(np.isfinite(f) & (f > 0))
    i = int(np.argmax(bad)) if np.any(bad) else len(grid) - 1
    u_top = float(np.nanmax(pot._U(grid[: i + 1])))
    where = (
        f"U'(q) = {f[i]:.6g} N at q = {grid[i]:.6g} m is not > 0"
        if bad[i]
        else f"U decreases before q = {q_end:.6g} m"
    )
    return NonMonotoneError(
        f"Expression: {where}: U = {_short(pot.source)} turns down at {u_top:.6g} J before "
        f"reaching the energy {energy:.6g} J (assumption 3 of section 3); lower the impact "
        "speed or fix U"
    )
