"""A contact potential U(q) written by the user as a formula, e.g. ``"k*q**3/3 + q**2/2"``.

The text is never executed. It is parsed with `ast.parse` and the syntax tree
is walked through a whitelist (numbers, ``q``, the declared parameters, a fixed
set of functions, the constants ``pi`` and ``E``, and ``+ - * / **``); the
sympy expression is built node by node from that walk. Derivatives come from
`sympy.diff`; evaluation goes through `sympy.lambdify` of that tree, so the
only code that runs is what sympy prints, and its only free name is ``q``
(parameter values are substituted as exact numbers first).

Numbers are exact: an integer literal is a sympy Integer and a float literal
or parameter value the rational of its shortest decimal form (0.1 -> 1/10), so
``q**3/3`` stays a rational cubic, identities such as ``(q + 0.1)**2 - 0.01``
vanish exactly at 0, and the float64 path sees exactly the float the user
wrote. The 50-digit path uses the decimal value, which differs from the binary
float by < 1 ulp for non-dyadic numbers.
"""

from __future__ import annotations

import math
from functools import cached_property
from typing import Any

import mpmath
import numpy as np
import sympy as sp

from reference_impl.errors import ExpressionError, HCVInputError, NonMonotoneError
from reference_impl.potentials._expr_budget import ExpressionTimeout, analysis_budget
from reference_impl.potentials._expr_parse import (
    _Q,
    _as_float,
    _check_expr,
    _check_inputs,
    _parse,
    _short,
    check_digits,
)
from reference_impl.potentials._expr_turning import check_rising, rising_inverse
from reference_impl.potentials._families import register_family
from reference_impl.potentials._near_zero import (
    FLOAT_RTOL,
    PowerSeries,
    SeriesTimeout,
    float_range,
    mp_accurate,
    strip_abs,
    time_limit,
)
from reference_impl.potentials._terms import sympy_power_rows
from reference_impl.potentials.base import Potential, is_mp

__all__ = ["Expression"]

# The numeric checks near q = 0 run in 60 digits (no power underflows) at these
# overlaps (m); two values of q U'/U agreeing to _N_RTOL give the leading exponent.
_N_DPS = 60
_N_PROBES = ("1e-30", "1e-45")
_N_RTOL = 1e-9
# Series orders (beyond the leading exponent) tried for the branch near 0; each
# try is checked against the raised-precision reference before it is used.
_SERIES_EXTRA_ORDERS = (24, 48, 96)
# Overlap (m) at which an exact series replacing a formula that is inaccurate
# everywhere is checked (the top of the float-floor scan).
_SCAN_TOP_Q = 100.0
# Wall-time budget (s) of one sympy series: q - atan(q) to order 99 takes 0.3 s;
# past the budget the float64 path evaluates at raised precision instead.
_SERIES_SECONDS = 2.0
# Where the series branch is checked, as fractions of the branch point.
_SERIES_CHECK_FRACTIONS = (1.0, 0.5, 0.1, 1e-2, 1e-4)
# Extra digits of the mpmath path above the float floor: there the formula loses
# at most ~2 digits (it is float64-accurate to 1e-14), 5 covers that.
_MP_GUARD_DPS = 5
# Wall-time budget (s) of the whole analysis of one expression (every sympy step:
# parse, diff, lambdify, limits, series, expansion): the issue asks <= 10 s; ordinary
# contact laws take well under 1 s, nested ones (sin 4 deep) a few seconds.
_ANALYSIS_SECONDS = 10.0
# Most digits of a number in the first three derivatives (they multiply the parser's
# <= 400-digit constants by exponents, three times): far below Python's 4300-digit
# int-to-str limit that sympy's printing hit (issue 36).
_MAX_DERIVATIVE_DIGITS = 2000
# Below this overlap (m) the float floor scan has no points: the mpmath path
# always raises its precision there.
_MP_TINY_Q = 1e-300


def _limit0(expr: sp.Expr) -> sp.Expr | None:
    """lim_{q -> 0+} expr, or None when sympy cannot find it."""
    try:
        val = sp.limit(expr, _Q, 0, "+")
    except (NotImplementedError, ValueError, TypeError, RecursionError):
        return None
    if isinstance(val, sp.Limit) or val.has(sp.AccumBounds) or not val.is_number:
        return None
    return val


def _to_mpf(value: sp.Expr | None) -> mpmath.mpf:
    """A sympy constant (possibly +-oo) at the current mpmath precision; nan for None."""
    if value is None:
        return mpmath.nan
    if value.is_infinite:
        return mpmath.mpf(_as_float(value))
    return mpmath.mpf(sp.N(value, mpmath.mp.dps + 5))


def _mp_probe(func, probe: str):
    """func(probe) in _N_DPS digits, as mpf, mpc (not real) or nan (not computable)."""
    with mpmath.workdps(_N_DPS):
        try:
            value = func(mpmath.mpf(probe))
        except (ZeroDivisionError, ValueError, TypeError, OverflowError):
            return mpmath.nan
        return +value if isinstance(value, (mpmath.mpf, mpmath.mpc)) else mpmath.mpf(value)


@register_family
class Expression(Potential):
    """Contact potential given as a formula in the overlap ``q``.

    Parameters
    ----------
    source : str
        U(q) in joules as a Python-syntax formula in ``q`` (metres), e.g.
        ``"k*q**3/3 + q**2/2"``. Allowed: int and float numbers, ``q``, the
        names in ``params``, ``pi``, ``E``, the operators ``+ - * / **`` and
        unary ``+ -``, and one-argument calls of ``sqrt, exp, log, sin, cos,
        tan, sinh, cosh, tanh, atan, asinh, abs``. Nothing else; at most 2000
        characters, numbers of at most 400 digits, transcendental calls nested at
        most 4 deep, and at most 10 s of analysis (sympy's limits and series).
    **params : float
        Values of the named parameters in ``source`` (SI units consistent with
        U in J and q in m). Every parameter must appear in ``source``.

    Attributes
    ----------
    source : str
        The formula as given.
    expr, dexpr, d2expr : sympy.Expr
        U, U' and U'' in the real symbol ``q``, parameters substituted.
    sympy_U : sympy.Expr
        Same as ``expr``: the validated U (stable name for exact solvers).
    sympy_symbol : sympy.Symbol
        The real symbol ``q`` of ``sympy_U``.
    leading_exponent : float
        n of U ~ c q^n as q -> 0+ (lim q U'/U by sympy; a raised-precision
        estimate only when sympy finds no limit).
    leading_coefficient : float
        c of U ~ c q^n (J/m^n), by sympy's lim U/q^n; c > 0 is required.

    Raises
    ------
    ExpressionError
        The formula is malformed, uses a name or construct outside the
        whitelist, does not depend on q, is not real, has a constant beyond
        float64 or beyond the digit or nesting bounds, its analysis ran past its
        time budget, or a parameter is invalid or unused.
    HCVInputError
        U(0) is not 0 (assumption 2 of section 3), or the leading exponent n
        of U ~ c q^n at q -> 0+ cannot be found or is not > 0.
    NonMonotoneError
        U is not positive just above q = 0 (assumption 3 of section 3).

    Notes
    -----
    Round-off is not physics: U(0) = 0, n and the sign of c are decided by
    sympy, never from a float evaluation near 0. Formulas that cancel near 0
    (``q - atan(q)``, ``1 - cos(q)``, ``exp(q) - 1 - q``) are evaluated there
    by their Puiseux series (float64, below the overlap where the formula
    itself stops being accurate to 1e-14, both checked against mpmath at
    raised precision) or at raised precision; ``abs(a)`` is replaced by ``a``
    or ``-a`` where the sign of a is fixed for q > 0, and refused otherwise.

    A non-zero force at contact (n = 1, e.g. ``exp(q) - 1`` or
    ``1 - exp(-q)``, U'(0+) = c) and an infinite one (n < 1, ``sqrt(q)``) are
    accepted: the assumptions of section 3 concern q >= 0 only, and the
    quadratures handle any n > 0. For n < 2 the supremum of U'/sqrt(2U) is
    infinite, so Delta t_safe of section 6 is 0.

    Monotonicity (U' > 0) and the existence of a turning point for a given
    energy are checked by `turning_point` / `check_monotone`, as for every
    potential; ``q_sup`` is infinite and ``q_scale`` 1 m. The inverse of U
    climbs from below the root, so the formula needs to be defined and
    increasing only up to the turning point.

    Examples
    --------
    >>> U = Expression("k*q**3/3 + q**2/2", k=2.0)
    >>> U.dU(0.5)
    1.0
    """

    family = "expression"
    scene_keys = (("U",), ("params",))
    label = "user expression U(q) in J (whitelisted formula, parameters in [potential.params])"

    def __init__(self, source: str, **params: float):
        _check_inputs(source, params)
        self.source = source
        self._params = dict(params)
        self._stage = "parse"
        try:
            # Every sympy step of the analysis inside one wall-time budget (`_expr_budget`:
            # SIGALRM stops the work where it is; the parser's static bounds hold it down
            # where no alarm can be used).
            with analysis_budget(_ANALYSIS_SECONDS):
                self._analyse()
        except ExpressionTimeout:
            raise ExpressionError(
                f"Expression: the analysis of U = {_short(source)} ran past "
                f"{_ANALYSIS_SECONDS:g} s (at its {self._stage}); simplify the formula "
                "(fewer nested functions) or use a built-in family"
            ) from None

    def _analyse(self) -> None:
        """Parse, differentiate, compile and check the formula (`__init__`, under its budget);
        ``_stage`` names the step under way, for the message of an expired budget."""
        source = self.source
        self.expr = strip_abs(_parse(source, self._params), source)
        _check_expr(self.expr, source)
        self._stage = "derivatives"
        self.dexpr = sp.diff(self.expr, _Q)
        self.d2expr = sp.diff(self.dexpr, _Q)
        exprs = (self.expr, self.dexpr, self.d2expr)
        # The kernels differentiate once more (the third derivative, `exact._nodes`) and
        # print every form (`_expr_cache.numba_numbers`, lambdify): no number beyond Python's
        # 4300-digit int-to-str limit may reach them.
        d3expr = sp.diff(self.d2expr, _Q)
        for what, e in (("U'", self.dexpr), ("U''", self.d2expr), ("U'''", d3expr)):
            check_digits(e, what, source, _MAX_DERIVATIVE_DIGITS)
        self._stage = "lambdify"
        # lambdify runs code that sympy prints from the whitelisted tree; the
        # only free name in it is q (parameters are already numbers).
        self._np_funcs = tuple(sp.lambdify(_Q, e, modules="numpy") for e in exprs)
        self._mp_funcs = tuple(sp.lambdify(_Q, e, modules="mpmath") for e in exprs)
        self._zero_limits: dict[int, sp.Expr | None] = {}
        self._stage = "limit U(0)"
        self._check_zero()
        self._n_exact: sp.Expr | None = None
        self._stage = "leading exponent (limit of q U'/U at q -> 0+)"
        self.leading_exponent = self._find_leading_exponent()
        self._check_real()
        self._stage = "leading coefficient (limit of U/q^n at q -> 0+)"
        self.leading_coefficient = self._find_leading_coefficient()
        self._stage = "float range and series near q = 0"
        self._setup_near_zero()
        # What later calls would ask of sympy, asked here under the budget: the limits of
        # U' and U'' at q = 0 (`_eval` at q = 0) and the term table (an expansion).
        self._stage = "limits of U' and U'' at q = 0"
        self._limit_at_zero(1)
        self._limit_at_zero(2)
        self._stage = "term table (expansion)"
        if self.float_formula_accurate:  # the only case `_term_rows` reads it
            _ = self._power_rows

    # -- public interface used by the exact solvers ---------------------------------
    @property
    def sympy_U(self) -> sp.Expr:
        """The validated U(q) as a sympy expression in `sympy_symbol` (parameters substituted)."""
        return self.expr

    @property
    def sympy_symbol(self) -> sp.Symbol:
        """The sympy symbol of the overlap q in `sympy_U` (declared real)."""
        return _Q

    @property
    def float_formula_accurate(self) -> bool:
        """True when U, U', U'' evaluated from `sympy_U` in float64 need no correction.

        False when a formula cancels near contact (q - atan(q), 1 - cos(q): the series
        branch takes over below a floor) or far from it (mpmath above a ceiling). Code
        that compiles `sympy_U` directly (the exact solver's kernels, the Verlet
        lanes) must use it only when this is True, and otherwise go through `U`,
        `dU`, `d2U`, which apply the corrections.
        """
        return self._q_branch == 0.0 and all(math.isinf(c) for c in self._ceilings)

    # -- construction checks --------------------------------------------------
    def _check_zero(self) -> None:
        """U(0) = 0 exactly (assumption 2), by substitution or the limit q -> 0+."""
        u0 = self.expr.subs(_Q, 0)
        if not (u0.is_number and u0.is_finite):
            u0 = _limit0(self.expr)
        if u0 is not None and u0.is_zero is None:
            # A constant sympy cannot decide, e.g. sqrt(2)**3 - 2*sqrt(2) unexpanded.
            u0 = sp.Integer(0) if abs(sp.N(u0, _N_DPS)) < 10 ** -(_N_DPS - 5) else u0
        if u0 is None or not u0.is_zero:
            shown = "undetermined" if u0 is None else str(u0)
            if u0 is not None and (len(shown) > 30 or not u0.is_Rational):
                shown = f"{_as_float(u0):.6g}" if not math.isnan(_as_float(u0)) else _short(shown)
            raise HCVInputError(
                f"Expression: U(0) = {shown} but assumption (2) of section 3 needs U(0) = 0; "
                f"subtract the constant from U = {_short(self.source)}"
            )

    def _find_leading_exponent(self) -> float:
        """n with U ~ c q^n as q -> 0+: lim q U'/U, from sympy or numerically."""
        n_sym = _limit0(_Q * self.dexpr / self.expr)
        if n_sym is not None:
            n = _as_float(n_sym)
            self._n_exact = n_sym
        else:
            u, du = self._mp_funcs[:2]
            a, b = (mp_accurate(lambda x: x * du(x) / u(x), p, 60.0, dps=_N_DPS) for p in _N_PROBES)
            agree = all(isinstance(v, mpmath.mpf) and mpmath.isfinite(v) for v in (a, b)) and (
                abs(a - b) <= _N_RTOL * abs(b)
            )
            n = float(b) if agree else math.nan
        where = f"of U = {_short(self.source)} at q -> 0+"
        if math.isnan(n):
            raise HCVInputError(
                f"Expression: cannot determine the leading exponent n (U ~ c q^n) {where}; "
                "the quadratures need a power-law onset, rewrite U so that it has one"
            )
        if not 0 < n < math.inf:
            raise HCVInputError(
                f"Expression: the leading exponent n = {n:.6g} {where} is not a finite number "
                "> 0; the quadratures need U ~ c q^n with 0 < n < inf"
            )
        return n

    def _check_real(self) -> None:
        """U is real just above q = 0 (60 digits: no power underflows)."""
        probe = _N_PROBES[-1]
        value = _mp_probe(self._mp_funcs[0], probe)
        if isinstance(value, mpmath.mpc) and value.imag != 0:
            raise ExpressionError(
                f"Expression: U({probe}) = {mpmath.nstr(value, 6)} J is not real; "
                f"U = {_short(self.source)} must be real for q >= 0"
            )

    def _find_leading_coefficient(self) -> float:
        """c of U ~ c q^n at q -> 0+, decided exactly; c > 0 is assumption 3 at the onset."""
        c_sym = _limit0(self.expr / _Q**self._n_exact) if self._n_exact is not None else None
        src = _short(self.source)
        if c_sym is not None and (c_sym.is_zero or c_sym.is_infinite):
            raise HCVInputError(
                f"Expression: U / q^n -> {c_sym} as q -> 0+ with n = {self.leading_exponent:.6g}: "
                f"U = {src} is not c q^n times 1 + o(1) at contact (a logarithmic factor?); the "
                "quadratures need a power-law onset"
            )
        if c_sym is None:
            # No symbolic limit: U(q) / q^n at a tiny overlap, at raised precision.
            probe = mpmath.mpf(_N_PROBES[-1])
            with mpmath.workdps(_N_DPS):
                u = mp_accurate(self._mp_funcs[0], probe, self.leading_exponent, dps=_N_DPS)
                c = u / probe ** mpmath.mpf(self.leading_exponent)
            c_val = float(c) if mpmath.isfinite(c) else math.nan
            positive = bool(mpmath.isfinite(c) and c > 0)
        else:
            c_val = _as_float(c_sym)
            positive = bool(c_sym.is_positive)
        if not positive:
            raise NonMonotoneError(
                f"Expression: U ~ {c_val:.6g} q^{self.leading_exponent:.6g} as q -> 0+, but U "
                f"must rise from U(0) = 0 (assumption 3 of section 3); check the sign of U = {src}"
            )
        return c_val

    def _setup_near_zero(self) -> None:
        """Choose where the float64 path switches from the formula to the series of U at 0.

        Each formula is trusted between its float floor and ceiling (where it
        matches the raised-precision value to 1e-14); below the floor, the
        Puiseux series of U (and its term-wise derivatives) is used once it has
        been checked against the same reference. If no series passes, the
        float64 path falls back to mpmath at raised precision below the floor.
        """
        n = self.leading_exponent
        self._series: tuple[PowerSeries, ...] | None = None
        self._mp_series_radius: dict[int, tuple[float, ...]] = {}
        # Per formula (U, U', U''): below its float floor the formula cancels;
        # from its ceiling on (cancellation far from contact) mpmath takes over.
        ranges = [float_range(f, g, n) for f, g in zip(self._np_funcs, self._mp_funcs, strict=True)]
        self._branches = tuple(r[0] for r in ranges)
        self._ceilings = tuple(r[1] for r in ranges)
        self._q_branch = max(self._branches)
        if self._q_branch == 0.0:
            return
        for extra in _SERIES_EXTRA_ORDERS:
            try:
                with time_limit(_SERIES_SECONDS):
                    s0 = PowerSeries(self.expr, int(math.ceil(n)) + extra)
                    series = (s0, s0.derivative(), s0.derivative().derivative())
            except (ValueError, TypeError, NotImplementedError, ZeroDivisionError, SeriesTimeout):
                return
            if self._series_ok(series):
                self._series = series
                return

    def _series_ok(self, series) -> bool:
        """Each series matches the raised-precision reference below its formula's floor."""
        for ser, mp_f, qb in zip(series, self._mp_funcs, self._branches, strict=True):
            if qb == 0.0:
                continue
            if not math.isfinite(qb):
                # The formula is inaccurate even at the top of the scan: only an
                # exact (terminating) series, e.g. of (q + 1e20)**2 - 1e40, can stand in.
                if math.isfinite(ser.gap):
                    return False
                qb = _SCAN_TOP_Q
            for frac in _SERIES_CHECK_FRACTIONS:
                q = np.array([qb * frac])
                ref = mp_accurate(mp_f, q[0], self.leading_exponent)
                if not mpmath.isfinite(ref):
                    return False
                val = float(ser.eval_float(q)[0])
                if abs(ref) > 1e-300 and not abs(mpmath.mpf(val) - ref) <= FLOAT_RTOL * abs(ref):
                    return False
        return True

    # -- evaluation -----------------------------------------------------------
    def _limit_at_zero(self, i: int) -> sp.Expr | None:
        """lim q -> 0+ of formula i (cached: sympy's limit is slow); U(0) = 0 by construction."""
        if i not in self._zero_limits:
            exprs = (sp.Integer(0), self.dexpr, self.d2expr)
            self._zero_limits[i] = exprs[0] if i == 0 else _limit0(exprs[i])
        return self._zero_limits[i]

    def _eval(self, i: int, q):
        """Formula i (0: U, 1: U', 2: U'') at q; the exact limit where q = 0 gives inf/nan.

        Below the float floor ``_q_branch`` (where the formula cancels) the
        float64 path uses the checked series of U at 0, or mpmath at raised
        precision when no series passed; the mpmath path uses the series where
        its truncation error is below the working precision and otherwise
        raises the precision until the value settles.
        """
        if is_mp(q):
            return self._eval_mp(i, q)
        q = np.asarray(q, dtype=float)
        with np.errstate(all="ignore"):
            out = np.asarray(self._np_funcs[i](q), dtype=float)
        # A formula constant in q (U'' of a quadratic) comes back as a scalar.
        out = np.array(np.broadcast_to(out, q.shape), dtype=float)
        near = np.asarray(q < self._branches[i])  # an array also for 0-d q
        if np.any(near) and self._series is not None:
            out[near] = self._series[i].eval_float(q[near])
            near[...] = False
        slow = near | (q >= self._ceilings[i])
        if np.any(slow):
            with mpmath.workdps(20):
                out[slow] = [
                    float(mp_accurate(self._mp_funcs[i], float(x), self.leading_exponent))
                    for x in q[slow]
                ]
        # U(0) = 0 was proved exactly at construction; round-off of a formula such
        # as (q + 0.1)**2 - 0.01 must not turn it into 1.7e-18.
        fix = (q == 0) & ((i == 0) | ~np.isfinite(out))
        if np.any(fix):
            out[fix] = _as_float(self._limit_at_zero(i))
        return out

    def _eval_mp(self, i: int, q):
        dps = mpmath.mp.dps
        if q == 0:
            return _to_mpf(self._limit_at_zero(i))
        if self._series is not None:
            if dps not in self._mp_series_radius:
                self._mp_series_radius[dps] = tuple(
                    s.mp_radius(b, FLOAT_RTOL, dps + 3)
                    for s, b in zip(self._series, self._branches, strict=True)
                )
            if q < self._mp_series_radius[dps][i]:
                return self._series[i].eval_mp(q)
        if q < self._branches[i] or q < _MP_TINY_Q or q >= self._ceilings[i]:
            out = mp_accurate(self._mp_funcs[i], q, self.leading_exponent, dps=dps)
        else:
            with mpmath.workdps(dps + _MP_GUARD_DPS):
                try:
                    out = self._mp_funcs[i](q)
                except (ZeroDivisionError, ValueError, TypeError):
                    out = mpmath.nan
                out = mpmath.mpf(mpmath.re(out)) if isinstance(out, mpmath.mpc) else out
        return +mpmath.mpf(out)

    def _U(self, q):
        return self._eval(0, q)

    def _dU(self, q):
        return self._eval(1, q)

    def _d2U(self, q):
        return self._eval(2, q)

    def check_monotone(self, q_max: float) -> None:
        """U' > 0 on a dense grid of (0, q_max], each float failure re-decided at raised
        precision (`reference_impl.potentials._expr_turning.check_rising`)."""
        check_rising(self, q_max)

    def _inverse(self, u: np.ndarray) -> np.ndarray:
        """Overlap q with U(q) = u by a bracket that climbs from below the root
        (`reference_impl.potentials._expr_turning.rising_inverse`)."""
        return rising_inverse(self, u)

    # -- term table (contract item 8) ---------------------------------------------
    def _term_rows(self):
        """Power rows when U is a sum of constants times q**e (e > 0), else None.

        Read exactly from the expanded sympy form (`sympy_power_rows`, which also
        refuses an expansion whose terms have both signs), and only when
        `float_formula_accurate`: a formula that cancels in float64 (q - atan(q)) must
        not be compiled from its terms, so it has no table. The rows are those of the
        same law written as `PowerLaw` terms: ``q**2.5/2.5`` is ``PowerLaw(1, 1.5)``.
        """
        if not self.float_formula_accurate:
            return None
        return self._power_rows

    @cached_property
    def _power_rows(self):
        # Read once (sp.expand of a long sum is not free): the kernels ask per call.
        rows = sympy_power_rows(self.expr, _Q)
        return None if rows is None else tuple(rows)

    # -- description ------------------------------------------------------------
    def params(self) -> dict[str, Any]:
        return {"U": self.source, "params": dict(self._params)}

    @classmethod
    def from_scene(cls, read) -> Expression:
        params = read.numbers("params") if read.has("params") else {}
        return cls(read.text("U"), **params)

    def __repr__(self) -> str:
        extra = "".join(f", {k}={v!r}" for k, v in self._params.items())
        return f"Expression({self.source!r}{extra})"
