"""High-precision ground truth: mpmath's Taylor-series ODE solver for one impact.

Integrates the contact equation of section 8,

    m q'' + C(q) q' + U'(q) = 0,   q(0) = 0,  q'(0) = v0 > 0,
    U'(q) = sum_i k_i q^p_i,       C(q) = c q^e,

with ``mpmath.odefun`` (a Taylor method of degree ~1.5 dps) until q returns to 0,
and locates the return (q = 0) and the maximum penetration (q' = 0) with
``mpmath.findroot`` on the solver's dense output.

Analyticity is required: the Taylor series of the solution are built from the
right-hand side at points on both sides of the path, including q = 0 at entry and
exit, so a force k q^p with non-integer p (Hertz p = 3/2) or a damping exponent
e that is not a non-negative integer is not analytic there and the series would
silently lose accuracy. Such cases are refused with `HCVInputError`. Accepted:
`PowerLaw` with integer p, and sums of such power laws; the force is evaluated
with integer powers, so its continuation to q < 0 past the exit is the polynomial
one. Damping C = c q^((p-1)/2) (the section 9 law) is analytic for odd p.

The problem is solved in scaled variables Q = q / L, V = q' / v0, s = t v0 / L
with L the conservative turning point, so the solution is O(1) on an O(1)
interval whatever the units (odefun's steps are at most 1/2 in s).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from numbers import Real

import mpmath

from reference_impl.errors import HCVInputError
from reference_impl.potentials.base import Potential, SumPotential
from reference_impl.potentials.power import PowerLaw

__all__ = ["TaylorImpact", "taylor_impact", "taylor_zero_crossings"]

# Guard digits of the working precision over the requested dps.
_GUARD_DPS = 10
# Scan step (scaled time s) used to bracket sign changes of Q and V before the
# root refinement: small next to the scaled half-period (pi/2 for a linear
# spring, O(1) for every power law), so no double crossing hides in one step.
_SCAN_STEP = mpmath.mpf(1) / 8
# Give up when q has not returned to 0 by this scaled time (about 20 contact
# times of a linear spring, ~10 s of series building): an overdamped contact
# that creeps back towards 0 without crossing it.
_SCAN_MAX = 64


@dataclass(frozen=True)
class TaylorImpact:
    """Result of `taylor_impact`; every number an mpmath.mpf accurate to ~dps digits.

    Attributes
    ----------
    contact_time : mpmath.mpf
        Time from entry (q = 0, q' = v0) to exit (q = 0 again), s.
    exit_velocity : mpmath.mpf
        q' at exit, m/s (negative: the body leaves the wall).
    restitution : mpmath.mpf
        Coefficient of restitution -exit_velocity / v0 (dimensionless).
    max_penetration : mpmath.mpf
        Largest overlap q at q' = 0, m.
    time_of_max_penetration : mpmath.mpf
        Time at which q' = 0, s.
    dps : int
        Requested decimal digits.
    """

    contact_time: mpmath.mpf
    exit_velocity: mpmath.mpf
    restitution: mpmath.mpf
    max_penetration: mpmath.mpf
    time_of_max_penetration: mpmath.mpf
    dps: int


def _integer_exponent(value: float) -> int | None:
    """The integer equal to ``value``, or None when it is not an integer."""
    return int(value) if float(value).is_integer() else None


def _force_terms(pot: Potential) -> list[tuple[float, int]]:
    """(k_i, p_i) of an analytic force sum k_i q^p_i, or HCVInputError."""
    terms = pot.terms if isinstance(pot, SumPotential) else (pot,)
    out = []
    for t in terms:
        if not isinstance(t, PowerLaw):
            raise HCVInputError(
                f"the Taylor solver needs a force analytic along the path, a sum of PowerLaw "
                f"terms with integer exponents; got a term {t!r}, whose force is not a "
                "polynomial in q (use the scipy or quadrature routes for it)"
            )
        p = _integer_exponent(t.p)
        if p is None:
            raise HCVInputError(
                f"the Taylor solver needs an integer force exponent: U'(q) = k q^{t.p!r} of {t!r} "
                "is not analytic at q = 0 (entry and exit of the contact), so the Taylor "
                "series would silently lose accuracy there (use the scipy or quadrature routes)"
            )
        out.append((t.k, p))
    return out


def _check_inputs(pot, m, v0, c_coeff, c_exponent, dps) -> tuple[list[tuple[float, int]], int]:
    """Validate everything; return the force terms (k_i, p_i) and the integer damping exponent."""
    if not isinstance(pot, Potential):
        raise HCVInputError(f"potential must be a Potential instance, got {pot!r}")
    for name, val, unit, strict in (
        ("mass m", m, "kg", True),
        ("impact speed v0", v0, "m/s", True),
        ("damping coefficient c_coeff", c_coeff, "N s/m^(1+e)", False),
    ):
        if isinstance(val, bool) or not isinstance(val, Real) or not math.isfinite(val):
            raise HCVInputError(f"{name} must be a finite real number ({unit}), got {val!r}")
        if val < 0 or (strict and val == 0):
            raise HCVInputError(
                f"{name} must be {'> 0' if strict else '>= 0'} ({unit}), got {val!r}"
            )
    if (
        isinstance(c_exponent, bool)
        or not isinstance(c_exponent, Real)
        or not math.isfinite(c_exponent)
    ):
        raise HCVInputError(f"damping exponent must be a finite real number, got {c_exponent!r}")
    e = _integer_exponent(c_exponent)
    if e is None or e < 0:
        raise HCVInputError(
            f"the Taylor solver needs a damping C(q) = c q^e analytic at q = 0, i.e. an integer "
            f"e >= 0; got e = {c_exponent!r} (for the section 9 law e = (p-1)/2 this means odd p)"
        )
    if isinstance(dps, bool) or not isinstance(dps, int) or dps < 5:
        raise HCVInputError(f"dps (decimal digits) must be an integer >= 5, got {dps!r}")
    return _force_terms(pot), e


def _solve(pot, terms, m, v0, c_coeff, e):
    """odefun solution y(s) = [Q, V] in scaled variables, and the scales L (m), tau (s).

    ``terms`` and ``e`` come from `_check_inputs`; runs at the caller's mpmath precision.
    """
    E = 0.5 * m * v0 * v0
    L = mpmath.mpf(pot.turning_point(E, check=False))  # length scale only; need not be exact
    mm, vv = mpmath.mpf(m), mpmath.mpf(v0)
    # V' = -(b Q^e V + sum_i a_i Q^p_i), a_i = k_i L^(p_i+1) / (m v0^2), b = c L^(e+1) / (m v0).
    a = [(mpmath.mpf(k) * L ** (p + 1) / (mm * vv * vv), p) for k, p in terms]
    b = mpmath.mpf(c_coeff) * L ** (e + 1) / (mm * vv)

    def rhs(s, y):
        Q, V = y
        force = sum(ai * Q**p for ai, p in a)  # integer powers: the polynomial continuation
        return [V, -(b * Q**e * V + force)]

    y = mpmath.odefun(rhs, 0, [mpmath.mpf(0), mpmath.mpf(1)])
    return y, L, L / vv


def _bracketed_root(f, lo, hi):
    """Root of f in [lo, hi] (a sign change) by the bracketing Anderson-Bjorck method."""
    root = mpmath.findroot(f, (lo, hi), solver="anderson")
    if not lo <= root <= hi:
        raise ArithmeticError(f"root refinement left the bracket [{lo}, {hi}]")
    return root


def _crossings(y, count: int, component: int):
    """Scaled times of the first ``count`` sign changes of y(s)[component], s > 0."""
    found = []
    s_prev = mpmath.mpf(0)
    v_prev = y(_SCAN_STEP / 1024)[component]  # just after s = 0 (Q = 0 there exactly)
    s = _SCAN_STEP
    while len(found) < count:
        if s > _SCAN_MAX:
            raise ArithmeticError(
                f"no sign change {len(found) + 1} of the {'velocity' if component else 'overlap'} "
                f"by scaled time {_SCAN_MAX}: the contact does not end (overdamped?)"
            )
        v = y(s)[component]
        if v == 0 or mpmath.sign(v) != mpmath.sign(v_prev):
            found.append(_bracketed_root(lambda x: y(x)[component], s_prev, s))
            v_prev = -v_prev
        else:
            v_prev = v
        s_prev = s
        s += _SCAN_STEP
    return found


def taylor_impact(
    pot: Potential, m: float, v0: float, c_coeff: float = 0.0, c_exponent: float = 0, dps: int = 30
) -> TaylorImpact:
    """One impact m q'' + c q^e q' + U'(q) = 0 from q = 0, q' = v0, by mpmath.odefun.

    Parameters
    ----------
    pot : Potential
        `PowerLaw` with integer p, or a `SumPotential` of such (force analytic at 0).
    m : float
        Mass in kg (> 0).
    v0 : float
        Impact speed in m/s (> 0).
    c_coeff : float
        Damping coefficient c >= 0 of C(q) = c q^e, in N s / m^(1+e).
    c_exponent : int
        Damping exponent e, a non-negative integer.
    dps : int
        Decimal digits of the results (computed with guard digits).

    Returns
    -------
    TaylorImpact
        Contact time (s), exit velocity (m/s), restitution, maximum penetration (m)
        and its time (s).

    Raises
    ------
    HCVInputError
        Non-analytic force or damping law, or invalid numbers.
    ArithmeticError
        The contact does not end within the scan horizon.
    """
    terms, e = _check_inputs(pot, m, v0, c_coeff, c_exponent, dps)
    with mpmath.workdps(dps + _GUARD_DPS):
        y, L, tau = _solve(pot, terms, m, v0, c_coeff, e)
        s_max = _crossings(y, 1, 1)[0]
        s_out = _crossings(y, 1, 0)[0]
        V_out = y(s_out)[1]
        return TaylorImpact(
            contact_time=tau * s_out,
            exit_velocity=mpmath.mpf(v0) * V_out,
            restitution=-V_out,
            max_penetration=L * y(s_max)[0],
            time_of_max_penetration=tau * s_max,
            dps=dps,
        )


def taylor_zero_crossings(
    pot: Potential,
    m: float,
    v0: float,
    count: int = 2,
    c_coeff: float = 0.0,
    c_exponent: float = 0,
    dps: int = 30,
):
    """Times (s) of the first ``count`` returns of q to 0 after the start at q = 0.

    The force continues past q = 0 as the polynomial sum k_i q^p_i. For odd p
    that continuation is the mirror image of the contact (U(|q|), a two-sided
    oscillator), so the second crossing is its full period; for even p the body
    escapes to q -> -infinity and there is no second crossing (ArithmeticError).

    Parameters
    ----------
    pot, m, v0, c_coeff, c_exponent, dps
        As in `taylor_impact`.
    count : int
        Number of crossings to locate (>= 1).

    Returns
    -------
    tuple of mpmath.mpf
        Crossing times in s, increasing.
    """
    if isinstance(count, bool) or not isinstance(count, int) or count < 1:
        raise HCVInputError(f"count must be an integer >= 1, got {count!r}")
    terms, e = _check_inputs(pot, m, v0, c_coeff, c_exponent, dps)
    with mpmath.workdps(dps + _GUARD_DPS):
        y, _, tau = _solve(pot, terms, m, v0, c_coeff, e)
        return tuple(tau * s for s in _crossings(y, count, 0))
