"""Action variable, period and contact duration of Theorem 1 (section 4).

Everything here uses the paper's own definitions, with E in joules, m in kg,
q in metres:

* action          J(E)   = sqrt(2 m) / pi * int_0^q_max sqrt(E - U(q)) dq      (J s)
* paper's period  T(E)   = 4 * sqrt(m / 2) * int_0^q_max dq / sqrt(E - U(q))   (s)
  (four times the "quarter period" of the proof of Theorem 1)
* contact time    t_c(E) = 2 * sqrt(m / 2) * int_0^q_max dq / sqrt(E - U(q))  (s)
  (q = 0 inwards to q = 0 outwards; half of T)
* dJ/dE                  = sqrt(2 m) / (2 pi) * int_0^q_max dq / sqrt(E - U(q)) (s)

The module does not decide whether T = 2 pi dJ/dE; it only evaluates both sides
(the verification suite measures the ratio).

Two independent numerical routes are provided.

Float64 (``action``, ``period``, ...): [0, q_max] is split at q_max / 2.

* Upper piece: q = q_max (1 - w^2) removes the 1/sqrt endpoint singularity, and
  E - U(q) is *not* formed as a difference (which would cancel catastrophically
  near q_max) but as the integral of the force, U(q_max) - U(q) =
  int_q^q_max U'(s) ds, by a Gauss rule; divided by w^2 it is a smooth positive
  function A(w), so both integrands 1/sqrt(A) and w^2 sqrt(A) are analytic.
* Lower piece: q = (q_max/2) s^4 turns the fractional powers of U at q = 0
  (Hertz q^2.5, volumetric V^(alpha+1)) into powers s^(4 n) with n > 1, smooth
  enough that a Gauss-Legendre rule converges to round-off.

mpmath (``action_mp``, ...): tanh-sinh (``mpmath.quad``) on the same two pieces,
the upper one in w with q = q_max - w^2. The substitution is needed: mpmath's
tanh-sinh nodes stop about 2^-prec from an end of the interval and are rounded
there, so a 1/sqrt singularity left in the integrand costs half the digits. A
plain ``mpmath.quad`` of 1/sqrt(E - U) over [0, q_max] gave a 3e-21 relative
error at 40 digits (Hertz, against the Beta closed form) while its own error
estimate claimed 1e-27. U(q_max) - U(q_max - w^2) is evaluated at twice the
working precision (a two-term Taylor expansion for the tiniest w), so the
cancellation next to the turning point costs nothing. q_max is found with
``mpmath.findroot`` at the working precision. dJ/dE is computed with
``mpmath.diff`` of J, a route independent of the Leibniz identity.

Closed forms for the power law U = k q^n / n (n = p + 1), with
q_max = (n E / k)^(1/n):

    int_0^q_max dq / sqrt(E - U) = q_max / sqrt(E) * B(1/n, 1/2) / n
    int_0^q_max sqrt(E - U) dq   = q_max sqrt(E)   * B(1/n, 3/2) / n

(substitute q = q_max y^(1/n) to get Euler's Beta integral); they live in
`reference_impl.theory.action_closed`.
"""

from __future__ import annotations

import math
from numbers import Real

import mpmath
import numpy as np

from reference_impl.errors import HCVInputError
from reference_impl.potentials.base import Potential
from reference_impl.potentials.power import PowerLaw

__all__ = [
    "action",
    "period",
    "contact_duration",
    "dJ_dE",
    "turning_point_mp",
    "action_mp",
    "period_mp",
    "contact_duration_mp",
    "dJ_dE_mp",
    "dJ_dE_identity_mp",
]

# --- float64 quadrature -------------------------------------------------------
# Split point of [0, q_max] as a fraction of q_max: below it E - U >= E - U(q_max/2)
# is bounded away from 0; above it the turning-point substitution applies.
_SPLIT = 0.5
# Upper limit of w for the upper piece: q_max (1 - w^2) = _SPLIT q_max.
_W_SPLIT = math.sqrt(1.0 - _SPLIT)
# Exponent of the lower-piece substitution q = q_split s^_S_POWER: a term q^beta
# (beta > 1 for every contact potential) becomes s^(4 beta + 3), whose Gauss
# error decays like N^-(8 beta + 8); 4 keeps the map itself gentle.
_S_POWER = 4
# Gauss-Legendre sizes. The integrands are analytic on the pieces with their
# nearest singularity (q = 0 or the complex roots of U = E) at Bernstein
# parameter rho >= 2.3, so rho^(-2N) is below 1e-30 for these N; more nodes only
# add round-off. Measured against the Beta closed forms for p in [0.1, 5]: <= 4e-15.
_N_UPPER = 40
_N_LOWER = 48
# Nodes of the inner rule for U(q_max) - U(q) = int_q^q_max U'(s) ds; the
# interval [q, q_max] stays in [q_max/2, q_max], a Bernstein parameter >= 5.8
# from the singularity of U' at 0, so 24 nodes give < 1e-30.
_N_INNER = 24


def _gauss01(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre nodes and weights on [0, 1]."""
    x, w = np.polynomial.legendre.leggauss(n)
    return 0.5 * (x + 1.0), 0.5 * w


_GU_X, _GU_W = _gauss01(_N_UPPER)
_GL_X, _GL_W = _gauss01(_N_LOWER)
_GI_X, _GI_W = _gauss01(_N_INNER)

# --- mpmath --------------------------------------------------------------------
# Guard digits added to the requested dps for every mpmath computation, so that
# the returned value is correct to the requested number of digits.
_GUARD_DPS = 10
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
# input checks
# ==================================================================================
def _check_pot(pot) -> None:
    if not isinstance(pot, Potential):
        raise HCVInputError(f"potential must be a Potential instance, got {pot!r}")


def _check_positive(name: str, value, unit: str) -> None:
    """Raise unless ``value`` is a finite real number > 0 (float, int or mpf)."""
    ok_type = isinstance(value, (Real, mpmath.mpf)) and not isinstance(value, bool)
    if not ok_type:
        raise HCVInputError(f"{name} must be a real number in {unit}, got {value!r}")
    finite = mpmath.isfinite(value) if isinstance(value, mpmath.mpf) else math.isfinite(value)
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


# ==================================================================================
# float64 route
# ==================================================================================
def _integrals(pot: Potential, E: float, q_max: float) -> tuple[float, float]:
    """The two basic integrals of Theorem 1 in float64.

    Returns
    -------
    I_inv : float
        int_0^q_max dq / sqrt(E - U(q)), in m / sqrt(J).
    I_sqrt : float
        int_0^q_max sqrt(E - U(q)) dq, in m sqrt(J).
    """
    # Upper piece, q = q_max (1 - w^2), w in [0, _W_SPLIT]: dq = -2 q_max w dw and
    # U(q_max) - U(q) = (q_max - q) int_0^1 U'(q + (q_max - q) t) dt = w^2 A(w) with
    # A(w) = q_max int_0^1 U'(...) dt > 0, free of cancellation; the integrands are
    # 2 q_max / sqrt(A) and 2 q_max w^2 sqrt(A).
    w = _W_SPLIT * _GU_X
    q = q_max * (1.0 - w * w)
    s = q[:, None] + (q_max - q)[:, None] * _GI_X[None, :]
    A = q_max * (pot._dU(s.ravel()).reshape(s.shape) @ _GI_W)
    if not np.all(A > 0):
        raise HCVInputError(
            f"U'(q) is not > 0 near the turning point q_max = {q_max:.6g} m of {pot!r}"
        )
    sqrtA = np.sqrt(A)
    I_inv_up = 2.0 * q_max * _W_SPLIT * np.dot(_GU_W, 1.0 / sqrtA)
    I_sqrt_up = 2.0 * q_max * _W_SPLIT * np.dot(_GU_W, w * w * sqrtA)

    # Lower piece, q = q_split s^4, s in [0, 1]: E - U(q) >= E - U(q_split) > 0.
    q_split = _SPLIT * q_max
    sl = _GL_X
    ql = q_split * sl**_S_POWER
    jac = q_split * _S_POWER * sl ** (_S_POWER - 1)
    gap = E - pot._U(ql)
    if not np.all(gap > 0):
        raise HCVInputError(f"U(q) reaches E = {E:.6g} J below q_max/2 for {pot!r}: U not monotone")
    sg = np.sqrt(gap)
    I_inv_lo = np.dot(_GL_W, jac / sg)
    I_sqrt_lo = np.dot(_GL_W, jac * sg)
    return float(I_inv_up + I_inv_lo), float(I_sqrt_up + I_sqrt_lo)


def _float_setup(pot, m, E) -> tuple[float, float, float]:
    _check_all(pot, m, E)
    E = float(E)
    return float(m), E, pot.turning_point(E)


def action(pot: Potential, m: float, E: float) -> float:
    """Action J(E) = sqrt(2 m) / pi * int_0^q_max sqrt(E - U) dq (float64).

    Parameters
    ----------
    pot : Potential
        Contact potential U(q).
    m : float
        Mass in kg (> 0).
    E : float
        Energy in J (> 0, finite); the turning point must exist.

    Returns
    -------
    float
        J in J s, relative accuracy ~1e-14.
    """
    m, E, q_max = _float_setup(pot, m, E)
    return math.sqrt(2.0 * m) / math.pi * _integrals(pot, E, q_max)[1]


def period(pot: Potential, m: float, E: float) -> float:
    """The paper's period T(E) = 4 sqrt(m/2) int_0^q_max dq / sqrt(E - U) (float64).

    This is four times the "quarter period" of the proof of Theorem 1, i.e.
    twice the contact duration (see `contact_duration`).

    Parameters
    ----------
    pot : Potential
        Contact potential U(q).
    m : float
        Mass in kg (> 0).
    E : float
        Energy in J (> 0, finite).

    Returns
    -------
    float
        T in s.
    """
    m, E, q_max = _float_setup(pot, m, E)
    return 4.0 * math.sqrt(0.5 * m) * _integrals(pot, E, q_max)[0]


def contact_duration(pot: Potential, m: float, E: float) -> float:
    """Contact duration t_c(E) = 2 sqrt(m/2) int_0^q_max dq / sqrt(E - U) (float64).

    The time from q = 0 (moving in) to q = 0 (moving out) of the conservative
    contact; half of the paper's T.

    Parameters
    ----------
    pot : Potential
        Contact potential U(q).
    m : float
        Mass in kg (> 0).
    E : float
        Energy in J (> 0, finite).

    Returns
    -------
    float
        t_c in s.
    """
    m, E, q_max = _float_setup(pot, m, E)
    return 2.0 * math.sqrt(0.5 * m) * _integrals(pot, E, q_max)[0]


def dJ_dE(pot: Potential, m: float, E: float) -> float:
    """dJ/dE by the Leibniz identity sqrt(2m)/(2 pi) int_0^q_max dq/sqrt(E - U) (float64).

    Parameters
    ----------
    pot : Potential
        Contact potential U(q).
    m : float
        Mass in kg (> 0).
    E : float
        Energy in J (> 0, finite).

    Returns
    -------
    float
        dJ/dE in s.
    """
    m, E, q_max = _float_setup(pot, m, E)
    return math.sqrt(2.0 * m) / (2.0 * math.pi) * _integrals(pot, E, q_max)[0]


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
