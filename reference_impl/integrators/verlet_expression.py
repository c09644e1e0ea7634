"""A user `Expression` compiled into the lane kernel (sympy U', U -> numba).

`_expression_kernel` builds the same kernel as
`reference_impl.integrators.verlet_kernel._kernel` with the expression's force
in place of `_force_energy`; `_worth_compiling` decides when a batch repays
the compile. Used by `reference_impl.integrators.verlet.run_lanes`.
"""

from __future__ import annotations

import types

import numba
import numpy as np
import sympy as sp

from reference_impl.potentials.base import Potential
from reference_impl.integrators.verlet_kernel import _N_PAR, _PENDING, SCENE_WALLS, _kernel

# Compiled kernels of user expressions, keyed by the sympy form of (U', U):
# compiling costs a few seconds, so each distinct expression is compiled once per
# process; None records a form numba cannot compile (the numpy engine runs it).
_EXPR_KERNELS: dict = {}
# Distinct expressions kept compiled at once (each kernel holds ~1 MB of code).
_EXPR_KERNELS_MAX = 16


# Compile an expression's kernel under engine="auto" only when the numpy engine
# would take longer than the compile (~5 s, more on a loaded machine): the numpy
# engine pays ~1e-4 s per step whatever the lane count, and ~1e-6 s per lane-step.
_COMPILE_MIN_STEPS = 50_000
_COMPILE_MIN_LANE_STEPS = 10_000_000


def _worth_compiling(batch) -> bool:
    """True when the batch's step budget makes the numpy engine slower than a compile."""
    if len(batch) == 0:
        return False
    budget = np.maximum(batch.max_steps, batch.confirm_steps)
    return int(budget.max()) >= _COMPILE_MIN_STEPS or float(budget.sum()) >= _COMPILE_MIN_LANE_STEPS


def _expression_kernel(pot: Potential):
    """The lane kernel with U'(q), U(q) of an `Expression` compiled in; None if not possible.

    U' and U come from the expression's sympy tree (parameters substituted),
    printed by ``sympy.lambdify`` as math-module code and compiled with
    ``numba.njit`` (numpy error model: inf/nan instead of exceptions); the
    kernel is the same function as `_kernel` with this force in place of
    `_force_energy`. No user text is evaluated: only what sympy prints from the
    parsed, whitelisted tree, as for the numpy engine.
    """
    from reference_impl.potentials.expression import Expression

    if type(pot) is not Expression:  # exact type: a subclass may change the law
        return None
    key = sp.srepr((pot.dexpr, pot.expr))
    if key in _EXPR_KERNELS:
        return _EXPR_KERNELS[key]
    try:
        qs = [x for x in (pot.expr.free_symbols | pot.dexpr.free_symbols) if x.name == "q"]
        q = qs[0] if qs else sp.Symbol("q", real=True)
        fn = numba.njit(error_model="numpy")(sp.lambdify(q, (pot.dexpr, pot.expr), modules="math"))

        @numba.njit(inline="always", error_model="numpy")
        def force_energy(x, fam, par):
            a, b = fn(x)
            return float(a), float(b)

        src = _kernel.py_func
        env = dict(src.__globals__, _force_energy=force_energy)
        kern = numba.njit(types.FunctionType(src.__code__, env, "_kernel_expression"))
        _probe(kern, pot)
    except Exception:  # noqa: BLE001 -- any compile failure: the numpy engine runs it
        kern = None
    while len(_EXPR_KERNELS) >= _EXPR_KERNELS_MAX:
        _EXPR_KERNELS.pop(next(iter(_EXPR_KERNELS)))
    _EXPR_KERNELS[key] = kern
    return kern


def _probe(kern, pot: Potential) -> None:
    """Compile ``kern`` now (one lane, one step), so that a failure shows here."""
    one = np.ones(1)
    i1 = np.ones(1, dtype=np.int64)
    st = np.full(1, _PENDING, dtype=np.int64)
    kern(
        np.zeros(1, dtype=np.int64),
        np.zeros((1, _N_PAR)),
        float(pot.q_sup),
        1.0,
        SCENE_WALLS,
        0.0,
        one * 1e-3,
        one * 0.0,
        one,
        one * 0.0,
        one * np.inf,
        one * np.inf,
        i1,
        one * np.inf,
        i1,
        i1 * 0,
        i1 * 0,
        False,
        np.zeros(0, dtype=np.int64),
        1,
        0,
        10,
        np.full(1, np.inf),
        np.zeros((1, 6)),
        np.zeros((1, 4), dtype=np.int64),
        st,
        np.zeros(1, dtype=np.int64),
        np.zeros(1),
        np.zeros(1),
        np.zeros((1, 0)),
    )
