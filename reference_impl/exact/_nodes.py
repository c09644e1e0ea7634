"""Compiled (numba) evaluation of dq/dx at quadrature nodes, for every potential family.

The exact solver needs, at each node, q = U^-1(m x^2 / 2) and dq/dx = m x / U'(q).
Here one compiled call does every node of a branch:

* a single ellipsoid or sphere cap, U = Kn / (alpha + 1) V^(alpha + 1) with the
  cubic V = c0 (a q^2 - q^3 / 3): V at the node follows from u in closed form (one
  power, corrected for its float exponent; for alpha = 1/2 a cube root by arithmetic,
  `_cap_powers`), q from V by an
  interpolant of the cubic's root and one Halley step (arithmetic only, no node
  waiting on another; `_cap_root`), and U' without a second power,
  U' = (alpha + 1) u V' / V (`_cap_nodes`);
* every other family: a safeguarded Halley iteration on U (`_newton_loop`, the
  branches of one call advanced node by node together so that their independent
  chains overlap), warm-started from the previous node along the branch by log q against log u to
  second order (slope 1/sigma, sigma = q U' / U, and its rate), inside a bracket [lo, hi] that starts at
  [0, q_max] and shrinks with every step (a step leaving it is replaced by a
  bisection). Once the step is below _TAYLOR_RTOL the root is taken one step on,
  and U' there from its Taylor series (U'' and U''' come with U), which saves the
  evaluation that would only confirm convergence.

Families read the potential's public attributes:

* every family with a term table (`reference_impl.potentials._terms`: power laws,
  caps, sums of them, and user expressions that are sums of constants times powers
  of q, read exactly from the sympy form): those rows (`_TERM_*` codes, `_term_rows`)
  evaluated by one compiled function, compiled once and cached on disk;
* other user expressions: `sympy.lambdify` prints the validated sympy forms of
  U, U', U'' (parameters substituted as exact numbers) as ``math``-module code,
  which numba compiles; cached by the sympy expressions in the process, and on disk
  (`reference_impl._cache`: the printed code as a module keyed by its canonical form,
  so numba's disk cache keeps it between processes). The user's text itself is
  never evaluated.

`node_function(pot)` returns a callable (x array, m, q_max) -> (dq/dx, q)
arrays, or None when the family has no compiled form (the numpy path is used
then). `node_kernel(pot)` gives the compiled pieces the whole-impact kernels of
`_one_call` are built from.
"""

from __future__ import annotations

import math
import sys
from fractions import Fraction
from functools import lru_cache
from typing import TYPE_CHECKING, NamedTuple

import numba
import numpy as np

if TYPE_CHECKING:
    import sympy as sp
# sympy itself is imported where an expression is handled: a potential of another family
# solves without it (issue 20: start-up).

from reference_impl._expr_cache import (
    expression_module,
    numba_numbers,
    printed_function,
    record_files,
)
from reference_impl._jit import specialise
from reference_impl.exact._cap_nodes import DESCENT as _DESCENT
from reference_impl.exact._cap_nodes import NEWTON_MAX_ITER as _NEWTON_MAX_ITER
from reference_impl.exact._cap_nodes import cap_nodes as _cap_nodes
from reference_impl.potentials._terms import TERM_CAP, TERM_POWER, term_rows
from reference_impl.potentials.base import Potential

__all__ = ["NodeKernel", "node_function", "node_kernel", "expression_sympy", "substitution_order"]

# Term codes of the table form (column 0 of P), those of the potentials' term table:
# U = k q^n / n (columns k, n, h: the half-power flag), and the volumetric cap
# U = Kn / (alpha + 1) V^(alpha + 1), V = c0 (a q^2 - q^3 / 3) (columns Kn, alpha, a, c0).
_TERM_POWER = TERM_POWER
_TERM_CAP = TERM_CAP
_EPS = float(np.finfo(float).eps)
# Relative step below which the Halley iteration stops and takes the root one step on,
# with U' there from its Taylor series to U''' step^2 / 2. With r = step/q <= 3e-7, the
# dropped U'''' step^3 / 6 is at most n^3/6 r^3 <= 4e-17 of U' for n <= 21
# (impact.N_MAX), and the root's error after a Halley step, ~ n^2/2 r^3 <= 6e-18 of q:
# both below an ulp. From the second-order warm start most nodes need one evaluation.
_TAYLOR_RTOL = 3e-7
# Largest |2 e| of a power q**e computed by products and a square root instead of pow
# (Hertz e = 1.5 is q sqrt(q)): at most |h|/2 + 1 roundings, <= 3 ulps.
_HALF_POWER_MAX = 4
# Column 3 of a power term when its exponent is not such a half-integer.
_NOT_HALF = 99
# Relative distance within which a float exponent is taken as the nearby rational
# of small denominator (`substitution_order`): float quotients are off by ~1e-16.
_EXPONENT_RTOL = 1e-12
# The evaluator a copy of `_newton_loop` calls, bound by `specialise`.
_EV = None
# Empty parameter table of expression kernels (the signature is shared with terms).
_NO_TERMS = np.zeros((0, 5))


@numba.njit(cache=True, error_model="numpy")
def _power(q, e, h):  # pragma: no cover - compiled
    """q**e; by products and one square root when e = h/2 with |h| <= _HALF_POWER_MAX."""
    if h == _NOT_HALF:
        return q**e
    a = abs(h)
    r = 1.0
    for _ in range(a // 2):
        r *= q
    if a % 2 == 1:
        r *= math.sqrt(q)
    return r if h >= 0 else 1.0 / r


@numba.njit(cache=True, error_model="numpy")
def _terms_eval(q, P):  # pragma: no cover - compiled
    """U(q) and its first three derivatives for a table of terms (q > 0)."""
    u = 0.0
    du = 0.0
    d2u = 0.0
    d3u = 0.0
    iq = 1.0 / q  # one division for the second and third derivatives of every power term
    for i in range(P.shape[0]):
        if P[i, 0] == _TERM_POWER:
            k, n = P[i, 1], P[i, 2]
            f = k * _power(q, n - 1.0, int(P[i, 3]))  # this term's U'
            du += f
            u += f * q / n
            f2 = (n - 1.0) * f * iq
            d2u += f2
            d3u += (n - 2.0) * f2 * iq
        else:
            kn, alpha, a, c0 = P[i, 1], P[i, 2], P[i, 3], P[i, 4]
            v = c0 * q * q * (a - q / 3.0)
            s = c0 * q * (2.0 * a - q)  # V'
            s2 = 2.0 * c0 * (a - q)  # V''
            f = kn * v**alpha  # Kn V^alpha
            du += f * s
            u += f * v / (alpha + 1.0)
            d2u += f * (alpha * s * s / v + s2)
            # d/dq of Kn V^alpha (alpha V'^2 / V + V''), with V''' = -2 c0.
            d3u += f * (
                alpha * (alpha - 1.0) * s * s * s / (v * v) + 3.0 * alpha * s * s2 / v - 2.0 * c0
            )
    return u, du, d2u, d3u


def _newton_loop(x, m, q_hi, q_s, u_s, n_lead, P, g, qs):  # pragma: no cover - compiled
    """dq/dx into g and q into qs at the virtual displacements x, by the Halley inverse of
    _EV(q, P) -> (U and its first three derivatives) (see `specialise`). Each row of the
    2-D x is one branch, its nodes in order along it: each warm-starts the next.

    The rows advance together, node j of every row before node j + 1. Each row's chain
    of dependent operations (its start from its previous node, its steps) is the one it
    has alone, so every value is the same bit for bit, but the processor overlaps the
    independent chains of different rows (measured: 20% less time for three rows).
    """
    nr = x.shape[0]
    # Each row's previous node: q, u, 1/sigma and the start's curvature (q <= 0: none).
    q_pr = np.full(nr, -1.0)
    u_pr = np.zeros(nr)
    is_pr = np.zeros(nr)
    cv_pr = np.zeros(nr)
    for j in range(x.shape[1]):
        for r in range(nr):
            xj = x[r, j]
            u = 0.5 * m * xj * xj
            # Warm start: log q against log u to second order from the previous node,
            # else the leading power law.
            q_prev = q_pr[r]
            if q_prev > 0.0:
                lr = math.log(u / u_pr[r])
                q = q_prev * math.exp(lr * (is_pr[r] - cv_pr[r] * lr))
            else:
                q = q_s * (u / u_s) ** (1.0 / n_lead)
            lo, hi = 0.0, q_hi
            if not (q > lo and q < hi):
                q = 0.5 * hi
            du = np.nan
            d2u = 0.0
            for _ in range(_NEWTON_MAX_ITER):
                uq, du, d2u, d3u = _EV(q, P)
                f = uq - u
                if f < 0.0:
                    lo = q
                elif f > 0.0:
                    hi = q
                else:
                    break
                if not (du > 0.0 and du < np.inf):
                    q = math.sqrt(lo * hi) if lo > 0.0 else hi * _DESCENT
                    du = np.nan
                    continue
                # One division per step (a division costs several multiplications' time;
                # the step's rounding is far below an ulp of q near the root).
                idu = 1.0 / du
                step = f * idu
                # Halley's correction, used while it is mild (far from the root the
                # plain Newton step inside the bracket is the safer one).
                h = 0.5 * step * d2u * idu
                if abs(h) < 0.5:
                    step = step / (1.0 - h)
                if abs(step) <= _TAYLOR_RTOL * q:
                    du_t = du - step * (d2u - 0.5 * step * d3u)
                    q = q - step
                    if du_t > 0.0 and du_t < np.inf:
                        du = du_t
                        d2u = d2u - step * d3u
                    else:
                        # The third derivative overflowed (q^(n-4) leaves float range near
                        # q ~ 1e-100), and the series with it: U' evaluated at the root. It
                        # gave dq/dx = -0.0 for U' = q^0.25 + q^0.75 at x <= 1e-110.
                        _, du, d2u, _ = _EV(q, P)
                    break
                qn = q - step
                if not (qn > lo and qn < hi):
                    qn = math.sqrt(lo * hi) if lo > 0.0 else hi * _DESCENT
                q = qn
            else:
                du = np.nan  # not converged: the caller refuses the node
            g[r, j] = m * xj / du
            qs[r, j] = q
            if q > 0.0 and du > 0.0 and u > 0.0:
                # sigma = q U'/U = d log u / d log q, and its rate, for the next start
                # (by reciprocals: only the start depends on them, not the root).
                iu = 1.0 / u
                sig = q * du * iu
                dsig = sig * (1.0 - sig) + q * q * d2u * iu
                inv_sig = 1.0 / sig
                q_pr[r], u_pr[r], is_pr[r] = q, u, inv_sig
                cv_pr[r] = 0.5 * dsig * (inv_sig * inv_sig * inv_sig)


_newton_terms_nodes = specialise(_newton_loop, cache=True, _EV=_terms_eval)


@numba.njit(cache=True, error_model="numpy")
def _terms_nodes(x, m, q_hi, q_s, u_s, n_lead, P, g, qs):  # pragma: no cover - compiled
    """`nodes` of a table of terms (rows of x: branches): closed form for a single cap,
    row by row, else Halley."""
    if P.shape[0] == 1 and P[0, 0] == _TERM_CAP:
        for r in range(x.shape[0]):
            _cap_nodes(x[r], m, q_hi, P, g[r], qs[r])
    else:
        _newton_terms_nodes(x, m, q_hi, q_s, u_s, n_lead, P, g, qs)


def _term_rows(pot: Potential):
    """(code, 4 params) rows of this module's table form, or None.

    An adapter of the potentials' one term table (`term_rows`): a power row
    (k, n, p) becomes (k, n, h) with h the half-power flag of U' = k q^(n-1)
    (`_power_row`), a cap row is taken as it is (Kn, alpha, a, c0). A potential
    without a table, or with a term that has no kernel here (the saturating
    force), gives None.
    """
    rows = term_rows(pot)
    if rows is None:
        return None
    out = []
    for code, c1, c2, c3, c4 in rows:
        if code == TERM_POWER:
            out.append(_power_row(c1, c2))
        elif code == TERM_CAP:
            out.append((_TERM_CAP, c1, c2, c3, c4))
        else:
            return None
    return out


def _power_row(k: float, n: float) -> tuple:
    """The row of k q^n / n; column 3 is h = 2 (n - 1) when it is a small integer."""
    h2 = 2.0 * (n - 1.0)
    h = int(h2) if h2 == int(h2) and abs(h2) <= _HALF_POWER_MAX else _NOT_HALF
    return (_TERM_POWER, k, n, float(h), 0.0)


def expression_sympy(pot) -> tuple[sp.Expr, sp.Expr, sp.Symbol] | None:
    """(U, U', q) of an `Expression` as sympy objects, or None for other families.

    Reads the public sympy form (``sympy_U`` when the potentials package
    provides it, else the documented ``expr``/``dexpr`` attributes): the one
    accessor to switch when that interface changes.
    """
    sp = sys.modules.get("sympy")
    if sp is None:
        return None  # sympy not loaded: no sympy expression exists in this process
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
    """Compiled node loop for U, U', U'' of an expression, and its evaluator
    q -> (U and its first three derivatives) (cached by the sympy expressions,
    which carry the parameter values as exact numbers)."""
    import sympy as sp

    d2expr = sp.diff(dexpr, q)
    d3expr = sp.diff(d2expr, q)
    cached = _disk_cached_expression((expr, dexpr, d2expr, d3expr), q)
    if cached is not None:
        return cached
    # lambdify prints the validated sympy tree as math-module code; numba compiles it.
    # error_model="numpy": a division by zero gives inf/nan (refused by the caller's
    # finiteness check) instead of raising inside the compiled loop.
    fu, fdu, fd2u, fd3u = (
        numba.njit(error_model="numpy")(sp.lambdify(q, numba_numbers(e), modules="math"))
        for e in (expr, dexpr, d2expr, d3expr)
    )

    @numba.njit(error_model="numpy")
    def ev(qv, P):  # pragma: no cover - compiled
        return fu(qv), fdu(qv), fd2u(qv), fd3u(qv)

    return specialise(_newton_loop, cache=False, _EV=ev), ev


# The module `_disk_cached_expression` writes for one expression: the same code as the
# in-memory path above (sympy's print of the validated tree), in a file, so that numba's
# disk cache keeps it, and the kernels specialised around its `ev`, between processes.
_MODULE_HEAD = (
    '"""Generated by reference_impl.exact._nodes from a validated sympy expression."""\n'
    "from math import *  # noqa: F403 -- the names sympy's math printer uses\n"
    "import numba\n"
)
_JIT_LINE = '@numba.njit(cache=True, error_model="numpy")\n'
_EV_SOURCE = "def ev(qv, P):\n    return u0(qv), u1(qv), u2(qv), u3(qv)\n"


def _disk_cached_expression(exprs, q):
    """(node loop, evaluator) of U, U', U'', U''' compiled from a cached module, or None.

    None when the compile cache is unusable or sympy prints something the module
    cannot reproduce; the caller then compiles in memory.
    """
    import sympy as sp

    funcs = [printed_function(q, e, f"u{i}") for i, e in enumerate(exprs)]
    if any(f is None for f in funcs):
        return None
    source = _MODULE_HEAD + "".join("\n\n" + _JIT_LINE + f for f in [*funcs, _EV_SOURCE])
    module = expression_module("nodes", sp.srepr(exprs), source)
    if module is None:
        return None
    nodes = specialise(_newton_loop, cache=True, _EV=module.ev)
    nodes._hcv_entry = module.__name__  # the cache entry its specialised kernels belong to
    record_files(module.__name__, [module.u0, module.u1, module.u2, module.u3, module.ev, nodes])
    return nodes, module.ev


class NodeKernel(NamedTuple):
    """The compiled node loop of one potential and the constants it reads.

    ``nodes(x, m, q_hi, q_s, u_s, n_lead, P, g, qs)`` writes dq/dx and q at the
    virtual displacements x (2-D: each row one branch, its nodes in order) into the
    arrays g and qs of x's shape.
    ``terms`` is True for the table form (shared, disk-cached kernels).
    ``ev(q, P)`` gives U and its first three derivatives at one overlap q > 0.
    """

    nodes: object
    P: np.ndarray
    q_s: float
    u_s: float
    n_lead: float
    terms: bool
    ev: object = None


def node_kernel(pot: Potential) -> NodeKernel | None:
    """The `NodeKernel` of ``pot``, or None when its family has no compiled form."""
    rows = _term_rows(pot)
    if rows is not None:
        nodes, ev, P, terms = _terms_nodes, _terms_eval, np.array(rows, dtype=float), True
    else:
        sym = expression_sympy(pot)
        if sym is None or not getattr(pot, "float_formula_accurate", True):
            # The raw formula cancels somewhere in float64 (e.g. exp(q) - 1 - q near
            # 0): a compiled kernel would lose digits there, so the potential's
            # corrected evaluation (series / raised precision) is used instead.
            return None
        (nodes, ev), P, terms = _compiled_expression(*sym), _NO_TERMS, False
    q_s = float(min(pot.q_scale, pot.q_sup))
    u_s = float(pot._U(np.array([q_s]))[0])
    return NodeKernel(nodes, P, q_s, u_s, float(pot.leading_exponent), terms, ev)


def node_function(pot: Potential):
    """Compiled dq/dx at nodes for ``pot``: f(x, m, q_hi) -> (dq/dx, q) arrays, or None.

    ``q_hi`` must bracket every root from above (the turning point of the
    impact's energy, which `Potential.turning_point` has validated). The nodes
    of each row of a 2-D ``x`` (or of a 1-D one) should come in order along the
    branch: each warm-starts the next.
    """
    k = node_kernel(pot)
    if k is None:
        return None

    def f(x, m, q_hi):
        xa = np.asarray(x, dtype=float)
        rows = np.ascontiguousarray(xa.reshape(-1, xa.shape[-1]) if xa.ndim else xa.reshape(1, 1))
        g = np.empty_like(rows)
        q = np.empty_like(rows)
        k.nodes(rows, m, q_hi, k.q_s, k.u_s, k.n_lead, k.P, g, q)
        return g.reshape(xa.shape), q.reshape(xa.shape)

    return f


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
    """Exponents n_i of the terms q^n_i (times functions analytic in q), or None.

    Sums term by term, expressions from their sympy form (any constant times q**p,
    whether or not it has a table), every other family from its term table: q^n, or
    the cap C q^n (1 - q / 3a)^(alpha + 1) (analytic factor, n = 2 (alpha + 1)).
    """
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
        rows = _term_rows(pot)
        if rows is None:
            return None
        return [r[2] if r[0] == _TERM_POWER else 2.0 * (r[2] + 1.0) for r in rows]
    expr, _, q = sym
    out = []
    for term in expr.as_ordered_terms():
        coeff, e = term.as_coeff_exponent(q)
        if coeff.has(q) or not e.is_number:
            return None  # e.g. exp(q): not a q^p times a constant -- refuse, not guess
        out.append(float(e))
    return out
