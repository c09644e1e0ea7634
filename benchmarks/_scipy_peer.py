"""scipy's `solve_ivp` DOP853 with a lean scalar right-hand side: the second column of
`benchmarks.bench_exact` (Python per step; no speed claim rests on it, issue 27)."""

from __future__ import annotations

import math
from functools import lru_cache

import sympy as sp
from scipy.integrate import solve_ivp

from reference_impl import PowerLaw
from reference_impl.exact._nodes import expression_sympy
from reference_impl.theory.laws import law_from_dict

__all__ = ["scipy_dop853"]


def _scalar_funcs(pot):
    """Lean scalar U and U' (math module) for the ODE right-hand side."""
    sym = expression_sympy(pot)
    if sym is not None:
        expr, dexpr, q = sym
        return sp.lambdify(q, expr, modules="math"), sp.lambdify(q, dexpr, modules="math")
    if isinstance(pot, PowerLaw):
        k, p = pot.k, pot.p
        return (lambda q: k * q ** (p + 1) / (p + 1)), (lambda q: k * q**p)
    if hasattr(pot, "terms"):
        fs = [_scalar_funcs(t) for t in pot.terms]
        return (lambda q: sum(f[0](q) for f in fs)), (lambda q: sum(f[1](q) for f in fs))
    a, Kn, al = pot._a, pot.Kn, pot.alpha
    c0 = math.pi * pot._bc / a**2

    def U(q):
        return Kn / (al + 1) * (c0 * (a * q * q - q**3 / 3)) ** (al + 1)

    def dU(q):
        return Kn * (c0 * (a * q * q - q**3 / 3)) ** al * c0 * (2 * a * q - q * q)

    return U, dU


_funcs = lru_cache(maxsize=16)(_scalar_funcs)


def scipy_dop853(pot, m, v0, damping, rtol):
    """Contact time and restitution at q = 0 by scipy's DOP853; ``damping`` is the universal
    law's zeta (float) or a law of `reference_impl.theory.laws` (dict)."""
    U, dU = _funcs(pot)
    if isinstance(damping, dict):
        dl = law_from_dict(damping)
        terms, alpha, A, k, p = dl.terms(), dl.alpha, dl.A, pot.k, pot.p

        def C(q):
            c = sum(cj * q**ej for cj, ej in terms)
            if alpha:
                c += alpha * k * q**p
            if A:
                c += A * k * p * q ** (p - 1)
            return c
    else:
        cu = 2.0 * damping * math.sqrt(m)

        def C(q):
            return cu * dU(q) / math.sqrt(2.0 * U(q))

    def rhs(t, y):
        q, v = y
        if q <= 0.0:
            return [v, 0.0]
        return [v, -(dU(q) + C(q) * v) / m]

    def touch(t, y):
        return y[0]

    touch.terminal, touch.direction = True, -1
    q_scale = pot.turning_point(0.5 * m * v0 * v0, check=False)
    sol = solve_ivp(
        rhs,
        (0.0, 50.0 * q_scale / v0),
        [0.0, v0],
        method="DOP853",
        rtol=rtol,
        atol=[rtol * q_scale, rtol * v0],
        events=touch,
    )
    return float(sol.t_events[0][0]), -float(sol.y_events[0][0][1]) / v0
