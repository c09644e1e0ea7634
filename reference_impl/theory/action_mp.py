"""The mpmath route of `reference_impl.theory.action`: J, T, t_c and dJ/dE to any precision.

Split from the float64 route so that a float solve never imports mpmath (issue 20); the
names are re-exported by `reference_impl.theory.action`, where the method is described.
"""

from __future__ import annotations

import mpmath

from reference_impl.potentials.base import Potential
from reference_impl.theory._action_common import (
    _GUARD_DPS,
    _SPLIT,
    _check_all,
    _check_dps,
    _check_positive,
    _check_pot,
)

__all__ = [
    "turning_point_mp",
    "action_mp",
    "period_mp",
    "contact_duration_mp",
    "dJ_dE_mp",
    "dJ_dE_identity_mp",
]

# Extra bits for the evaluation of U(q_max) - U(q_max - d): the difference of two
# numbers near E loses log2(q_max / d) bits, up to the working precision itself.
_DELTA_U_EXTRA_BITS = 64
# Below d / q_max = 2^-(prec + _TAYLOR_GAP_BITS) the two-term Taylor expansion
# (U(q_max) - U(q_max - d)) / d = U'(q_max) - U''(q_max) d / 2 is used; its
# relative error ~(d / q_max)^2 is then far below 2^-prec.
_TAYLOR_GAP_BITS = 20
# Accept the tanh-sinh result when its error estimate is below 2^-(prec - this):
# quad's estimate is the difference of the last two levels, pessimistic by far.
_QUAD_SLACK_BITS = 16
# Extra degrees tried when quad's error estimate is not yet small enough.
_QUAD_EXTRA_DEGREE = 3
# addprec of mpmath.diff: the central difference with step h = E 2^-(prec+addprec)
# is evaluated at 2 (prec + 2 addprec) bits; truncation error (h/E)^2 and the
# cancellation loss prec + addprec both stay well below the target.
_DIFF_ADDPREC = 20


# ==================================================================================
# mpmath route (all helpers work at the current mpmath precision)
# ==================================================================================
def _turning_point_here(pot: Potential, E, q_guess: float):
    """q_max with U(q_max) = E at the current precision, by mpmath.findroot.

    Newton's method on the scaled residual U(q_guess r) / E - 1 (root r ~ 1), so
    that findroot's tolerances are relative; q_guess is the float64 turning point.
    """
    q0 = mpmath.mpf(q_guess)
    r = mpmath.findroot(
        lambda r: pot.U(q0 * r) / E - 1,
        mpmath.mpf(1),
        df=lambda r: q0 * pot.dU(q0 * r) / E,
        solver="newton",
    )
    return q0 * r


def _quad(f, a, b):
    """Tanh-sinh integral of f over [a, b], refined until its error estimate is small."""
    prec = mpmath.mp.prec
    target = mpmath.ldexp(1, -(prec - _QUAD_SLACK_BITS))
    degree = mpmath.calculus.quadrature.TanhSinh(mpmath.mp).guess_degree(prec)
    for extra in range(_QUAD_EXTRA_DEGREE + 1):
        val, err = mpmath.quad(f, [a, b], error=True, maxdegree=degree + extra)
        if err <= target * abs(val):
            return val
    raise ArithmeticError(
        f"mpmath.quad did not converge: error estimate {mpmath.nstr(err, 3)} for value "
        f"{mpmath.nstr(val, 10)} at {mpmath.mp.dps} digits"
    )


def _integral_mp(pot: Potential, E, q_max, kind: str):
    """int_0^q_max f(E - U(q)) dq at the current precision; f = 1/sqrt ('inv') or sqrt.

    Lower piece [0, q_max/2] in q directly (the integrand is bounded; tanh-sinh
    absorbs the fractional powers of U at q = 0). Upper piece in w with
    q = q_max - w^2: mpmath's tanh-sinh nodes stop at a distance ~2^-prec from an
    end and are rounded there, so a 1/sqrt(d) endpoint singularity would cost half
    the digits; after the substitution both integrands, 2 / sqrt(G) and
    2 w^2 sqrt(G) with G = (U(q_max) - U(q)) / w^2, are smooth and bounded.
    """
    prec = mpmath.mp.prec
    hi = 2 * prec + _DELTA_U_EXTRA_BITS
    q_split = q_max * _SPLIT
    with mpmath.workprec(hi):
        U_top = pot.U(q_max)
        dU_top = pot.dU(q_max)
        d2U_top = pot.d2U(q_max)
    d_taylor = q_max * mpmath.ldexp(1, -(prec + _TAYLOR_GAP_BITS))

    def G(w):
        # (U(q_max) - U(q_max - d)) / d with d = w^2, measured from the computed
        # q_max (consistent with it to twice the precision), so the cancellation
        # near the turning point costs nothing.
        with mpmath.workprec(hi):
            d = w * w
            if d < d_taylor:
                return dU_top - d2U_top * d / 2
            return (U_top - pot.U(q_max - d)) / d

    if kind == "inv":

        def upper(w):
            return 2 / mpmath.sqrt(G(w))

        def lower(q):
            return 1 / mpmath.sqrt(E - pot.U(q))
    else:

        def upper(w):
            return 2 * w * w * mpmath.sqrt(G(w))

        def lower(q):
            return mpmath.sqrt(E - pot.U(q))

    return _quad(lower, 0, q_split) + _quad(upper, 0, mpmath.sqrt(q_max - q_split))


def _mp_setup(pot, m, E, dps):
    """Validate the inputs; return the float64 turning point (m), the start of findroot."""
    _check_all(pot, m, E)
    _check_dps(dps)
    q_guess = pot.turning_point(float(E))  # also checks U' > 0 on (0, q_max]
    return q_guess


def turning_point_mp(pot: Potential, E, dps: int = 50):
    """Turning point q_max(E), U(q_max) = E, by mpmath.findroot at ``dps`` digits.

    Parameters
    ----------
    pot : Potential
        Contact potential.
    E : float or mpmath.mpf
        Energy in J (> 0).
    dps : int
        Decimal digits.

    Returns
    -------
    mpmath.mpf
        q_max in m.
    """
    _check_pot(pot)
    _check_positive("energy E", E, "J")
    _check_dps(dps)
    q_guess = pot.turning_point(float(E))
    with mpmath.workdps(dps + _GUARD_DPS):
        return _turning_point_here(pot, mpmath.mpf(E), q_guess)


def _action_here(pot, m, E, q_guess):
    q_max = _turning_point_here(pot, E, q_guess)
    return mpmath.sqrt(2 * m) / mpmath.pi * _integral_mp(pot, E, q_max, "sqrt")


def action_mp(pot: Potential, m, E, dps: int = 50):
    """Action J(E) = sqrt(2 m)/pi int_0^q_max sqrt(E - U) dq at ``dps`` digits.

    Parameters
    ----------
    pot : Potential
        Contact potential; its U, U', U'' must accept mpmath.mpf.
    m : float or mpmath.mpf
        Mass in kg (> 0).
    E : float or mpmath.mpf
        Energy in J (> 0). A float is taken as its exact binary value.
    dps : int
        Decimal digits of the result (computed with guard digits).

    Returns
    -------
    mpmath.mpf
        J in J s.
    """
    q_guess = _mp_setup(pot, m, E, dps)
    with mpmath.workdps(dps + _GUARD_DPS):
        return _action_here(pot, mpmath.mpf(m), mpmath.mpf(E), q_guess)


def _inv_integral_mp(pot, E, dps, q_guess):
    """int_0^q_max dq / sqrt(E - U) (m / sqrt(J)) at dps + guard digits."""
    with mpmath.workdps(dps + _GUARD_DPS):
        Em = mpmath.mpf(E)
        q_max = _turning_point_here(pot, Em, q_guess)
        return _integral_mp(pot, Em, q_max, "inv")


def period_mp(pot: Potential, m, E, dps: int = 50):
    """The paper's T(E) = 4 sqrt(m/2) int_0^q_max dq/sqrt(E - U) at ``dps`` digits.

    Parameters and units as in `action_mp`; returns T in s (mpmath.mpf).
    """
    I = _inv_integral_mp(pot, E, dps, _mp_setup(pot, m, E, dps))
    with mpmath.workdps(dps + _GUARD_DPS):
        return 4 * mpmath.sqrt(mpmath.mpf(m) / 2) * I


def contact_duration_mp(pot: Potential, m, E, dps: int = 50):
    """Contact duration t_c(E) = 2 sqrt(m/2) int_0^q_max dq/sqrt(E - U) at ``dps`` digits.

    Parameters and units as in `action_mp`; returns t_c in s (mpmath.mpf).
    """
    I = _inv_integral_mp(pot, E, dps, _mp_setup(pot, m, E, dps))
    with mpmath.workdps(dps + _GUARD_DPS):
        return 2 * mpmath.sqrt(mpmath.mpf(m) / 2) * I


def dJ_dE_identity_mp(pot: Potential, m, E, dps: int = 50):
    """dJ/dE by the Leibniz identity sqrt(2m)/(2 pi) int dq/sqrt(E - U), at ``dps`` digits.

    Parameters and units as in `action_mp`; returns dJ/dE in s (mpmath.mpf).
    """
    I = _inv_integral_mp(pot, E, dps, _mp_setup(pot, m, E, dps))
    with mpmath.workdps(dps + _GUARD_DPS):
        return mpmath.sqrt(2 * mpmath.mpf(m)) / (2 * mpmath.pi) * I


def dJ_dE_mp(pot: Potential, m, E, dps: int = 50):
    """dJ/dE by numerical differentiation (mpmath.diff) of J(E), at ``dps`` digits.

    Independent of the Leibniz identity: J is evaluated at E +- h with
    h = E 2^-(prec + 20) and twice the working precision (mpmath.diff's own
    precision management), each J by its own turning point and quadrature.

    Parameters
    ----------
    pot : Potential
        Contact potential (mpmath-capable).
    m : float or mpmath.mpf
        Mass in kg (> 0).
    E : float or mpmath.mpf
        Energy in J (> 0).
    dps : int
        Decimal digits of the result.

    Returns
    -------
    mpmath.mpf
        dJ/dE in s.
    """
    q_guess = _mp_setup(pot, m, E, dps)
    with mpmath.workdps(dps + _GUARD_DPS):
        mm, Em = mpmath.mpf(m), mpmath.mpf(E)
        h = Em * mpmath.ldexp(1, -(mpmath.mp.prec + _DIFF_ADDPREC))
        return mpmath.diff(
            lambda e: _action_here(pot, mm, e, q_guess), Em, h=h, addprec=_DIFF_ADDPREC
        )
