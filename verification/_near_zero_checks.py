"""What the tests of laws that cancel near q = 0 share: float tolerances and mpmath truths.

`test_potentials_near_zero.py` (the issue 8 / 12 formulas) and
`test_potentials_property.py` (random expressions) read them here. The truths are
independent of the code under test: plain mpmath evaluations of the sympy formula.
"""

from __future__ import annotations

import functools

import mpmath
import sympy as sp

from reference_impl.potentials import Expression

__all__ = ["_F64_RTOL", "_SOLVE_RTOL", "_contact_time_truth", "_reference"]

# Float64 values against the correctly rounded value: the formula above its
# float floor and the series below it are both held to 1e-14 (45 ulps) by
# construction; 2e-14 adds the rounding of the comparison itself.
_F64_RTOL = 2e-14
# Float64 contact time against the mpmath quadrature: the target
# accuracy for the exact solver (its tanh-sinh rules reach ~1e-15 here).
_SOLVE_RTOL = 1e-13
# Digits of the independent reference values: the formulas below cancel at most
# ~3 x 300 digits at q = 1e-300 m (q - atan(q) ~ q^3 from terms ~ q), so 1200
# digits leave > 250 correct; each value is confirmed at 100 more digits.
_REF_DPS = 1200
# Digits of the independent quadrature truth: E - U(q) cancels near q_max; at 60
# digits the cancelling stretch (s < 1e-22 in q = q_max (1 - s^2)) adds < 1e-22.
_TRUTH_DPS = 60


@functools.lru_cache(maxsize=64)
def _mp_function(expr: sp.Expr, sym: sp.Symbol):
    return sp.lambdify(sym, expr, modules="mpmath")


def _reference(
    expr: sp.Expr, sym: sp.Symbol, q: float, dps: int, work_dps: int = _REF_DPS
) -> mpmath.mpf:
    """expr at the exact binary q, in mpmath at work_dps digits, confirmed at +100 digits."""
    f = _mp_function(expr, sym)
    with mpmath.workdps(work_dps):
        val = f(mpmath.mpf(q))
    with mpmath.workdps(work_dps + 100):
        chk = f(mpmath.mpf(q))
    with mpmath.workdps(dps + 10):
        assert abs(val - chk) <= abs(chk) * mpmath.mpf(10) ** -(dps + 5), "reference unsettled"
    return +val


def _contact_time_truth(pot: Expression, m: float, v0: float) -> mpmath.mpf:
    """2 int_0^q_max dq / sqrt(2 (E - U(q)) / m) at 60 digits, q = q_max (1 - s^2)."""
    f = sp.lambdify(pot.sympy_symbol, pot.sympy_U, modules="mpmath")
    df = sp.lambdify(pot.sympy_symbol, sp.diff(pot.sympy_U, pot.sympy_symbol), modules="mpmath")
    with mpmath.workdps(_TRUTH_DPS):
        m_, E = mpmath.mpf(m), mpmath.mpf(m) * mpmath.mpf(v0) ** 2 / 2
        guess = mpmath.mpf(pot.turning_point(0.5 * m * v0**2))
        # Solved for y = q / guess ~ 1, so that mpmath's tolerances are relative.
        y = mpmath.findroot(lambda y: f(guess * y) / E - 1, (1, 1 + mpmath.mpf(10) ** -8))
        q_max = guess * y
        # Near s = 0, E - U = U'(q_max) q_max s^2 (1 + O(s^2)): the limit value.
        end = 2 * q_max / mpmath.sqrt(2 * df(q_max) * q_max / m_)

        # Integrand / (q_max / v0), which is O(1): mpmath's quad stops on an
        # absolute error estimate, so a contact time of 1e-150 s must be scaled.
        scale = q_max / mpmath.mpf(v0)

        def integrand(s):
            q = q_max * (1 - s * s)
            gap = E - f(q)
            if s < mpmath.mpf(10) ** -25 or gap <= 0:
                return end / scale
            return 2 * q_max * s / mpmath.sqrt(2 * gap / m_) / scale

        return 2 * scale * mpmath.quad(integrand, [0, mpmath.mpf(1) / 2, 1])
