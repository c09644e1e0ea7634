"""Compiled (numba) evaluation of dq/dx at quadrature nodes, for every potential family.

The exact solver needs, at each node, q = U^-1(m x^2 / 2) and dq/dx = m x / U'(q).
Through numpy each node costs a few microseconds of Python overhead; here one
compiled call does every node of one impact: a safeguarded Newton iteration on
log U against log q (Newton from the leading power-law guess, inside a bracket
[lo, hi] that starts at [0, q_max] and shrinks with every step; a step leaving
the bracket is replaced by a bisection), then the force.

Families dispatch on the potential's type and read its public attributes:

* power laws, ellipsoid and sphere caps, and sums of them: a table of terms
  (code, four parameters) evaluated by one compiled function (`_TERM_*` codes);
* user expressions: `sympy.lambdify` prints the validated sympy form (the
  expression's public ``expr`` and ``dexpr``, parameters already substituted as
  exact numbers) as ``math``-module code, which numba compiles; the result is
  cached by the sympy expressions. The user's text itself is never evaluated.

`node_function(pot)` returns a callable (x array, m, q_max) -> dq/dx array, or
None when the family has no compiled form (the numpy path is used then).
"""

from __future__ import annotations

import math
from fractions import Fraction
from functools import lru_cache

import numba
import numpy as np
import sympy as sp

from .potentials.base import Potential, SumPotential
from .potentials.power import PowerLaw
from .potentials.volumetric import Ellipsoid, Sphere

__all__ = ["node_function", "expression_sympy", "substitution_order"]

# Term codes of the table form: U = k q^n / n, and the volumetric cap
# U = Kn / (alpha + 1) V^(alpha + 1) with V = c0 (a q^2 - q^3 / 3).
_TERM_POWER = 0
_TERM_CAP = 1
# Relative step at which Newton stops: a few ulps of q (as the numpy inverse).
_NEWTON_XRTOL = 4.0 * np.finfo(float).eps
# Newton/bisection steps allowed per node (Newton needs ~4; bisection from [0, q_max]
# with geometric steps needs at most ~2200 to span float64).
_NEWTON_MAX_ITER = 3000
# Fraction of hi tried when the lower bracket is still 0 (geometric descent).
_DESCENT = 1.0 / 64.0
# Relative distance within which a float exponent is taken as the nearby rational
# of small denominator (`substitution_order`): float quotients are off by ~1e-16.
_EXPONENT_RTOL = 1e-12


@numba.njit(cache=True, error_model="numpy")
def _terms_U_dU(q, codes, P):  # pragma: no cover - compiled
    """U(q) and U'(q) of a table of terms."""
    u = 0.0
    du = 0.0
    for i in range(codes.shape[0]):
        if codes[i] == _TERM_POWER:
            k, n = P[i, 0], P[i, 1]
            qp = q ** (n - 1.0)
            du += k * qp
            u += k * qp * q / n
        else:
            kn, alpha, a, c0 = P[i, 0], P[i, 1], P[i, 2], P[i, 3]
            v = c0 * (a * q * q - q * q * q / 3.0)
            s = c0 * (2.0 * a * q - q * q)
            va = v**alpha
            du += kn * va * s
            u += kn / (alpha + 1.0) * va * v
    return u, du


@numba.njit(cache=True, error_model="numpy")
def _terms_nodes(x, m, q_hi, q_s, u_s, n_lead, codes, P):  # pragma: no cover - compiled
    out = np.empty_like(x)
    qs = np.empty_like(x)
    q_prev, lt_prev, slope_prev = -1.0, 0.0, 0.0
    for j in range(x.shape[0]):
        xj = x[j]
        u = 0.5 * m * xj * xj
        lo, hi = 0.0, q_hi
        lt = math.log(u)
        # Warm start: a log-log Newton step from the previous node (nodes come in
        # order along each branch), else the leading power law.
        if q_prev > 0.0:
            q = q_prev * math.exp((lt - lt_prev) / slope_prev)
        else:
            q = q_s * (u / u_s) ** (1.0 / n_lead)
        if not (q > lo and q < hi):
            q = 0.5 * hi
        uq, duq = _terms_U_dU(q, codes, P)
        for _ in range(_NEWTON_MAX_ITER):
            f = uq - u
            if f < 0.0:
                lo = q
            elif f > 0.0:
                hi = q
            else:
                break
            # Plain Newton on U (the warm start is already close; U - u keeps its
            # relative precision there), safeguarded by the bracket.
            step = f / duq if duq > 0.0 else math.inf
            if abs(step) <= _NEWTON_XRTOL * q:
                break  # converged: q is within a few ulps of the root
            qn = q - step
            if not (qn > lo and qn < hi):
                qn = math.sqrt(lo * hi) if lo > 0.0 else hi * _DESCENT
            q = qn
            uq, duq = _terms_U_dU(q, codes, P)
        out[j] = m * xj / duq
        qs[j] = q
        if uq > 0.0 and duq > 0.0:
            q_prev, lt_prev, slope_prev = q, math.log(uq), q * duq / uq
    return out, qs


def _term_rows(pot: Potential):
    """(code, 4 params) rows for power laws and caps, or None for other families."""
    if type(pot) is PowerLaw:
        return [(_TERM_POWER, (pot.k, pot.leading_exponent, 0.0, 0.0))]
    if type(pot) in (Ellipsoid, Sphere):
        c0 = math.pi * pot._bc / pot._a**2
        return [(_TERM_CAP, (pot.Kn, pot.alpha, pot._a, c0))]
    if type(pot) is SumPotential:
        rows = []
        for t in pot.terms:
            sub = _term_rows(t)
            if sub is None:
                return None
            rows += sub
        return rows
    return None


def expression_sympy(pot) -> tuple[sp.Expr, sp.Expr, sp.Symbol] | None:
    """(U, U', q) of an `Expression` as sympy objects, or None for other families.

    Reads the public sympy form (``sympy_U`` when the potentials package
    provides it, else the documented ``expr``/``dexpr`` attributes): the one
    accessor to switch when that interface changes.
    """
    expr = getattr(pot, "sympy_U", None)
    if expr is None:
        expr = getattr(pot, "expr", None)
    if not isinstance(expr, sp.Expr):
        return None
    syms = sorted(expr.free_symbols, key=str)
    if len(syms) != 1:
        return None
    q = syms[0]
    dexpr = getattr(pot, "dexpr", None)
    if not isinstance(dexpr, sp.Expr):
        dexpr = sp.diff(expr, q)
    return expr, dexpr, q


@lru_cache(maxsize=64)
def _compiled_expression(expr: sp.Expr, dexpr: sp.Expr, q: sp.Symbol):
    """Compiled node kernel for U and U' (cached by the sympy expressions, which
    carry the parameter values as exact numbers)."""
    # lambdify prints the validated sympy tree as math-module code; numba compiles it.
    # error_model="numpy": a division by zero gives inf/nan (refused by the caller's
    # finiteness check) instead of raising inside the compiled loop.
    fu = numba.njit(error_model="numpy")(sp.lambdify(q, expr, modules="math"))
    fdu = numba.njit(error_model="numpy")(sp.lambdify(q, dexpr, modules="math"))
    return _make_expression_kernel(fu, fdu)


def _make_expression_kernel(fu, fdu):
    @numba.njit(error_model="numpy")
    def nodes(x, m, q_hi, q_s, u_s, n_lead):  # pragma: no cover - compiled
        out = np.empty_like(x)
        qs = np.empty_like(x)
        q_prev, lt_prev, slope_prev = -1.0, 0.0, 0.0
        for j in range(x.shape[0]):
            xj = x[j]
            u = 0.5 * m * xj * xj
            lo, hi = 0.0, q_hi
            lt = math.log(u)
            # Warm start: a log-log Newton step from the previous node (nodes come in
            # order along each branch), else the leading power law.
            if q_prev > 0.0:
                q = q_prev * math.exp((lt - lt_prev) / slope_prev)
            else:
                q = q_s * (u / u_s) ** (1.0 / n_lead)
            if not (q > lo and q < hi):
                q = 0.5 * hi
            uq, duq = fu(q), fdu(q)
            for _ in range(_NEWTON_MAX_ITER):
                f = uq - u
                if f < 0.0:
                    lo = q
                elif f > 0.0:
                    hi = q
                else:
                    break
                # Plain Newton on U (the warm start is already close; U - u keeps its
                # relative precision there), safeguarded by the bracket.
                step = f / duq if duq > 0.0 else math.inf
                if abs(step) <= _NEWTON_XRTOL * q:
                    break  # converged: q is within a few ulps of the root
                qn = q - step
                if not (qn > lo and qn < hi):
                    qn = math.sqrt(lo * hi) if lo > 0.0 else hi * _DESCENT
                q = qn
                uq, duq = fu(q), fdu(q)
            out[j] = m * xj / duq
            qs[j] = q
            if uq > 0.0 and duq > 0.0:
                q_prev, lt_prev, slope_prev = q, math.log(uq), q * duq / uq
        return out, qs

    return nodes


def node_function(pot: Potential):
    """Compiled dq/dx at nodes for ``pot``: f(x, m, q_hi) -> (dq/dx, q) arrays, or None.

    ``q_hi`` must bracket every root from above (the turning point of the
    impact's energy, which `Potential.turning_point` has validated).
    """
    q_s = float(min(pot.q_scale, pot.q_sup))
    u_s = float(pot._U(np.array([q_s]))[0])
    n_lead = float(pot.leading_exponent)
    rows = _term_rows(pot)
    if rows is not None:
        codes = np.array([r[0] for r in rows], dtype=np.int64)
        P = np.array([r[1] for r in rows], dtype=float)

        def f_terms(x, m, q_hi):
            flat = np.ascontiguousarray(x, dtype=float).ravel()
            g, q = _terms_nodes(flat, m, q_hi, q_s, u_s, n_lead, codes, P)
            return g.reshape(np.shape(x)), q.reshape(np.shape(x))

        return f_terms
    sym = expression_sympy(pot)
    if sym is None:
        return None
    if not getattr(pot, "float_formula_accurate", True):
        # The raw formula cancels somewhere in float64 (e.g. exp(q) - 1 - q near 0):
        # the compiled kernel would lose digits there, so the potential's corrected
        # evaluation (series / raised precision) is used instead. Right before fast.
        return None
    kernel = _compiled_expression(*sym)

    def f_expr(x, m, q_hi):
        flat = np.ascontiguousarray(x, dtype=float).ravel()
        g, q = kernel(flat, m, q_hi, q_s, u_s, n_lead)
        return g.reshape(np.shape(x)), q.reshape(np.shape(x))

    return f_expr


def substitution_order(pot: Potential, max_order: int) -> int | None:
    """Smallest b <= max_order making every exponent of d in dq/dx / d^beta an
    integer multiple of 1/b, or None (unknown exponents, or denominators too large).

    With U = sum_i q^n_i (analytic in q) and q ~ x^(2/n), x = d h(d) (h analytic),
    the exponents are 1, 2/n and 2 (n_i - n)/n. Expressions qualify only when every
    term is a constant times q**p (read from the sympy form, exactly); any other
    term gives None.
    """
    n = pot.leading_exponent
    exps = _term_exponents(pot)
    if exps is None:
        return None
    fr = []
    for e in [2.0 / n] + [2.0 * (ni - n) / n for ni in exps]:
        f = Fraction(e).limit_denominator(max_order)
        # e is a float quotient of declared exponents (a few ulps off the rational);
        # a wrong b would only cost the caller's two-rule check (it falls back).
        if abs(float(f) - e) > _EXPONENT_RTOL * max(1.0, abs(e)):
            return None
        fr.append(f)
    b = 1
    for f in fr:
        b = b * f.denominator // math.gcd(b, f.denominator)
    return b if b <= max_order else None


def _term_exponents(pot):
    """Exponents n_i of the terms q^n_i (times functions analytic in q), or None."""
    if type(pot) in (PowerLaw, Ellipsoid, Sphere):
        # q^n, or the cap C q^n (1 - q / 3a)^(alpha + 1): analytic factor, one exponent.
        return [pot.leading_exponent]
    terms = getattr(pot, "terms", None)
    if terms is not None:
        out = []
        for t in terms:
            sub = _term_exponents(t)
            if sub is None:
                return None
            out += sub
        return out
    sym = expression_sympy(pot)
    if sym is None:
        return None
    expr, _, q = sym
    out = []
    for term in expr.as_ordered_terms():
        coeff, e = term.as_coeff_exponent(q)
        if coeff.has(q) or not e.is_number:
            return None  # e.g. exp(q): not a q^p times a constant -- refuse, not guess
        out.append(float(e))
    return out
