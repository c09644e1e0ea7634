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

import numpy as np

from reference_impl.errors import HCVInputError
from reference_impl.potentials.base import Potential
from reference_impl.theory._action_common import _SPLIT, _check_all

# The mpmath route's names (`reference_impl.theory.action_mp`), served by the module
# __getattr__ below so that the float route never imports mpmath.
_MP_NAMES = (
    "turning_point_mp",
    "action_mp",
    "period_mp",
    "contact_duration_mp",
    "dJ_dE_mp",
    "dJ_dE_identity_mp",
)
__all__ = ["action", "period", "contact_duration", "dJ_dE", *_MP_NAMES]

# --- float64 quadrature -------------------------------------------------------
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


def __getattr__(name: str):
    # The mpmath route loads on first use (`action_mp`): the float route needs no mpmath.
    if name in _MP_NAMES:
        from reference_impl.theory import action_mp

        return getattr(action_mp, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
