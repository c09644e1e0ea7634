"""Accurate evaluation of a formula U(q) near q = 0, where its float64 form cancels.

``q - atan(q)`` is q^3/3 for small q, but its float64 value is 0 below q ~ 1e-8
and wrong in every digit well above that: the two terms cancel. The same holds
for ``1 - cos(q)``, ``exp(q) - 1 - q`` and, in U' and U'', for most formulas
with a leading exponent above 1. This module gives `Expression` three tools:

* `mp_accurate`: a formula evaluated in mpmath at a precision raised until two
  evaluations agree (the reference for every decision near 0);
* `float_range`: the overlaps between which the float64 formula agrees with
  that reference (a scan of decades, decided at raised precision);
* `PowerSeries`: the exact (sympy) Puiseux series of U at 0, evaluated in float64
  or mpmath below the floor, with the leading term factored out so that neither
  cancellation nor a spurious underflow of an intermediate power occurs.

Decisions (the sign of the leading coefficient, the leading exponent) are made
on exact sympy objects; numbers are compared only at raised precision.
"""

from __future__ import annotations

import math

import mpmath
import numpy as np
import sympy as sp

from reference_impl.errors import ExpressionError
from reference_impl.potentials._expr_budget import SeriesTimeout, time_limit
from reference_impl.potentials._expr_parse import _Q, _short

__all__ = [
    "QPOS",
    "SeriesTimeout",
    "strip_abs",
    "mp_accurate",
    "float_range",
    "PowerSeries",
    "time_limit",
]

# A positive twin of the parser's real symbol q: series and sign decisions for
# q > 0 need positive=True, which the parser avoids for speed (see _expr_parse).
QPOS = sp.Symbol("q", positive=True)

# Digits the reference evaluation must reach (relative): well below float64's 16.
_REF_DPS = 24
# Extra digits of the first evaluation (then doubled until two evaluations agree).
_FIRST_EXTRA = 10
# Orders of q beyond the leading exponent that a subterm may vanish to (or be
# divided by in U''), for the a-priori precision bound of `_lead_digits`.
_CANCEL_MARGIN = 2
# Extra digits of the check evaluation that confirms a raised-precision value.
_CHECK_EXTRA = 20
# Largest working precision tried before giving up (digits): q ~ 1e-300 with a
# leading exponent of 30 cancels ~9000 digits; beyond that the formula is refused.
_MAX_DPS = 20000
# Relative accuracy demanded of the float64 path (formula or series): 45 ulps,
# far below the 1e-13 the solvers promise, above the few-ulp spread of a
# well-conditioned formula.
FLOAT_RTOL = 1e-14
# Overlaps scanned for the float floor: every decade down to 1e-20 m, then
# every tenth decade to 1e-300 m (cancellation only grows as q -> 0, so the
# floor is the lowest passing point of an unbroken run from the top); the decade
# above the first failure is refined in _SCAN_PER_DECADE steps.
_SCAN_TOP = 2
_SCAN_FINE_LOW = -20
_SCAN_LOW = -300
_SCAN_PER_DECADE = 8
# The refinement runs only where the decade grid is fine (below 1e2 m and above
# the tenth-decade steps).
_FINE_SCAN_ABOVE = 10.0**_SCAN_TOP
# Values beyond this magnitude range are not float64 numbers (overflow or
# subnormal); the float formula cannot be judged there, only skipped.
_FLOAT_MIN = 1e-300
_FLOAT_MAX = 1e307


def strip_abs(expr: sp.Expr, source: str) -> sp.Expr:
    """Replace each ``Abs(a)`` by ``a`` or ``-a`` where the sign of a is fixed for q > 0.

    Raises
    ------
    ExpressionError
        Some ``abs(...)`` changes sign (or sympy cannot decide its sign) for
        q > 0: U would have a kink there, outside assumption (1) of section 3.
    """

    def resolve(node: sp.Abs) -> sp.Expr:
        arg = node.args[0]
        pos = arg.subs(_Q, QPOS)
        if pos.is_nonnegative:
            return arg
        if pos.is_nonpositive:
            return -arg
        raise ExpressionError(
            f"Expression: the sign of abs({_short(str(arg))[1:-1]}) is not fixed for q > 0, so "
            f"U = {_short(source)} has a kink (assumption (1) of section 3 needs U twice "
            "differentiable); write the branch valid on your overlaps instead of abs"
        )

    if not expr.has(sp.Abs):
        return expr
    return expr.replace(lambda e: isinstance(e, sp.Abs), resolve)


def _lead_digits(q, n_lead: float) -> int:
    """A-priori bound on the digits a formula with U ~ q^n loses to cancellation at q.

    A subterm that vanishes like q^k, divided by q^j in a derivative, loses
    (k + j) |log10 q| digits; k + j <= n + 2 covers U, U' and U'' of the
    formulas met (sqrt(q) (1 - cos q): n = 2.5, U'' loses 2 |log10 q|). Two
    evaluations below this precision may agree on the same wrong value (a
    1 - cos(q) that is exactly 0 at both), so agreement is trusted only above it.
    """
    if not q or q >= 1:
        return 0
    return int(math.ceil((max(n_lead, 1.0) + _CANCEL_MARGIN) * -float(mpmath.log10(q)))) + 5


def mp_accurate(func, q, n_lead: float, dps: int | None = None):
    """``func(q)`` (an mpmath lambdified formula) to ``dps`` correct digits.

    The formula is evaluated at dps + e and dps + e + 20 digits, starting
    from e = the a-priori cancellation bound of `_lead_digits` and doubling e
    until the two agree to 10^-dps relative (agreement below that bound can be
    spurious: 1 - cos(q) is exactly 0 at any precision below 2 |log10 q|).
    Returns an mpf at the caller's precision (nan when the formula is not
    computable or does not settle below `_MAX_DPS` digits).

    Parameters
    ----------
    func : callable
        Formula in mpmath.
    q : mpf, float or str
        Overlap (m), taken as exact.
    n_lead : float
        Leading exponent of the formula's cancelling terms (bounds the digits lost).
    dps : int, optional
        Correct digits wanted; default `_REF_DPS`.
    """
    target = _REF_DPS if dps is None else dps
    qv = mpmath.mpf(q)
    cancel = _lead_digits(qv, n_lead)
    extra = max(_FIRST_EXTRA, cancel)
    while target + extra <= _MAX_DPS:
        with mpmath.workdps(target + extra):
            try:
                val = func(mpmath.mpf(qv))
                with mpmath.workdps(target + extra + _CHECK_EXTRA):
                    chk = func(mpmath.mpf(qv))
            except (ZeroDivisionError, ValueError, TypeError, OverflowError):
                return mpmath.nan
            if isinstance(val, mpmath.mpc) or isinstance(chk, mpmath.mpc):
                if mpmath.im(chk) != 0:
                    return mpmath.nan
                val, chk = mpmath.re(val), mpmath.re(chk)
            val, chk = mpmath.mpf(val), mpmath.mpf(chk)
            if not mpmath.isfinite(chk):
                return +chk
            if chk == 0:
                if val == 0:
                    return mpmath.mpf(0)
            elif abs(val - chk) <= abs(chk) * mpmath.mpf(10) ** (-target - 1):
                return +chk
        extra *= 2
    return mpmath.nan


def _scan_points() -> list[float]:
    """Decades 1e2 .. 1e-20 m, then every tenth decade to 1e-300 m."""
    fine = range(_SCAN_TOP, _SCAN_FINE_LOW - 1, -1)
    coarse = range(_SCAN_FINE_LOW - 10, _SCAN_LOW - 1, -10)
    return [10.0**k for k in (*fine, *coarse)]


def _float_ok(value: float, ref) -> bool | None:
    """Does float ``value`` match the reference? None when ref is no float64 number."""
    if not mpmath.isfinite(ref):
        return None
    mag = abs(ref)
    if mag != 0 and not _FLOAT_MIN <= mag <= _FLOAT_MAX:
        return None
    if not math.isfinite(value):
        return False
    return abs(mpmath.mpf(value) - ref) <= FLOAT_RTOL * mag if mag else value == 0.0


def float_range(np_func, mp_func, n_lead: float, q_sup: float = math.inf) -> tuple[float, float]:
    """(floor, ceiling) (m): where the float64 formula is accurate, judged at raised precision.

    Walks the scan points upward from 1e-300 m, comparing the float64 value
    with `mp_accurate` (relative tolerance `FLOAT_RTOL`; points where the true
    value is no float64 number are skipped). The floor is the first passing
    point after the run of failures that starts at the bottom (cancellation at
    contact), refined within the decade below it; 0.0 when the lowest judged
    point passes, inf when none does. The ceiling is the first failing point
    above the floor (1 - tanh(q)**2 in U'' of q - tanh(q) cancels beyond
    q ~ 10 m), inf when none fails up to the top of the scan.
    """

    def passes(qp: float) -> bool | None:
        with np.errstate(all="ignore"):
            val = float(np.asarray(np_func(np.array([qp])), dtype=float).ravel()[0])
        return _float_ok(val, mp_accurate(mp_func, qp, n_lead))

    points = [qp for qp in reversed(_scan_points()) if qp <= q_sup]
    failed = False
    floor = math.inf
    start = len(points)
    for k, qp in enumerate(points):
        ok = passes(qp)
        if ok is None:
            continue
        if ok:
            floor, start = qp, k + 1
            break
        failed = True
    if not failed:
        floor = 0.0
    ceiling = math.inf
    for qp in points[start:]:
        if passes(qp) is False:
            ceiling = qp
            break
    if not (failed and math.isfinite(floor)):
        return floor, ceiling
    if floor > _FINE_SCAN_ABOVE or floor < 10.0**_SCAN_FINE_LOW:
        return floor, ceiling
    # Refine within the decade below: a lower floor lets a series of finite
    # radius reach it (q - atan(q): 0.18 m, radius 1 m).
    for k in range(1, _SCAN_PER_DECADE):
        qp = floor * 10.0 ** (-k / _SCAN_PER_DECADE)
        if passes(qp) is False:
            break
        floor = qp
    return floor, ceiling


class PowerSeries:
    """Truncated Puiseux series sum_k a_k q^(e_k) of U, U' or U'' at q = 0+.

    Parameters
    ----------
    expr : sympy.Expr
        Formula in the parser's symbol q.
    order : int
        Series order passed to `sympy.series` (terms below q^order are kept).

    Attributes
    ----------
    coeffs, exps : list of sympy numbers
        Non-zero coefficients and exponents in increasing order of exponent.
    gap : float
        Exponent of the truncation error relative to the leading term (the
        error is O(q^gap) relative).

    Raises
    ------
    ValueError
        sympy's series has a term that is not a constant times a power of q
        (a logarithm, for instance), or no term at all.
    """

    def __init__(self, expr: sp.Expr, order: int):
        ser = sp.series(expr.subs(_Q, QPOS), QPOS, 0, n=order)
        big_o = ser.getO()
        body = sp.expand(ser.removeO())
        terms = []
        for term in sp.Add.make_args(body):
            if term == 0:
                continue
            coef, expo = term.as_coeff_exponent(QPOS)
            if coef.has(QPOS) or not (coef.is_number and expo.is_number):
                raise ValueError(f"series term {term} is not a constant times a power of q")
            terms.append((sp.nsimplify(expo) if expo.is_Float else expo, coef))
        if not terms:
            raise ValueError("the series has no non-zero term")
        terms.sort(key=lambda t: float(t[0]))
        self.exps = [e for e, _ in terms]
        self.coeffs = [c for _, c in terms]
        e0 = float(self.exps[0])
        if big_o is None:
            self.gap = math.inf
        else:
            o_exp = big_o.args[0].as_coeff_exponent(QPOS)[1]
            self.gap = float(o_exp) - e0
        self._prepare()

    def _prepare(self) -> None:
        a0, e0 = self.coeffs[0], self.exps[0]
        self._sign = 1.0 if a0 > 0 else -1.0
        self._e0 = float(e0)
        self._a0 = float(a0)
        # (alpha q)^e0 with alpha = |a0|^(1/e0) keeps c q^n finite wherever it
        # is a float64 number (1e300 q^2 at q = 1e-200 is 1e-100, but q**2 underflows).
        alpha = float(abs(a0) ** (1 / sp.Rational(e0))) if e0 != 0 else math.nan
        self._alpha = alpha if (math.isfinite(alpha) and alpha > 0) else None
        self._ratios = [float(c / a0) for c in self.coeffs[1:]]
        self._gaps = [float(e - e0) for e in self.exps[1:]]
        self._mp_cache: dict[int, tuple] = {}

    def derivative(self) -> PowerSeries:
        """Term-by-term derivative (valid inside the series' convergence region)."""
        new = object.__new__(PowerSeries)
        pairs = [(e - 1, c * e) for e, c in zip(self.exps, self.coeffs, strict=True) if e != 0]
        if not pairs:
            pairs = [(sp.Integer(0), sp.Integer(0))]
        new.exps = [e for e, _ in pairs]
        new.coeffs = [c for _, c in pairs]
        if new.coeffs[0] == 0 and len(pairs) > 1:
            new.exps, new.coeffs = new.exps[1:], new.coeffs[1:]
        e_old = float(self.exps[0]) + self.gap
        new.gap = e_old - 1 - float(new.exps[0])
        if new.coeffs[0] == 0:
            new.gap = math.inf
            new._zero = True
            return new
        new._prepare()
        return new

    def _lead(self, q: np.ndarray) -> np.ndarray:
        if self._e0 == 0:
            return np.full_like(q, self._a0)
        if self._alpha is not None:
            return self._sign * (self._alpha * q) ** self._e0
        return self._a0 * q**self._e0

    def eval_float(self, q: np.ndarray) -> np.ndarray:
        """Series value at float64 overlaps q >= 0 (m)."""
        q = np.asarray(q, dtype=float)
        if getattr(self, "_zero", False):
            return np.zeros_like(q)
        with np.errstate(all="ignore"):
            rel = np.zeros_like(q)
            for r, g in zip(reversed(self._ratios), reversed(self._gaps), strict=True):
                rel = rel + r * q**g
            return self._lead(q) * (1.0 + rel)

    def eval_mp(self, q):
        """Series value at an mpmath overlap q (current precision)."""
        if getattr(self, "_zero", False):
            return mpmath.mpf(0)
        dps = mpmath.mp.dps
        if dps not in self._mp_cache:
            self._mp_cache[dps] = tuple(
                (mpmath.mpf(sp.N(c, dps + 5)), mpmath.mpf(sp.N(e, dps + 5)))
                for c, e in zip(self.coeffs, self.exps, strict=True)
            )
        return mpmath.fsum(c * q**e for c, e in reversed(self._mp_cache[dps]))

    def mp_radius(self, q_ok: float, err_ok: float, digits: int) -> float:
        """Overlap below which the truncation error is < 10^-digits (relative).

        Scales the error ``err_ok`` measured at ``q_ok`` by (q / q_ok)^gap.
        """
        if getattr(self, "_zero", False) or not math.isfinite(self.gap):
            return math.inf
        if q_ok <= 0:
            return 0.0
        err_ok = max(err_ok, FLOAT_RTOL)
        return q_ok * (10.0 ** (-digits) / err_ok) ** (1.0 / self.gap)
