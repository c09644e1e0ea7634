"""Critical damping (zeta = 1 and a few ulps around it) in every batch path (issue 36, item 4).

`solve_impacts` divided by omega_d = sqrt(1 - zeta^2) = 0 inside a numba ``prange`` loop
when zeta = 1 sat among its damping ratios: the first call answered, and that call's
exception, which numba cannot carry out of a parallel loop, came back as ``SystemError``
on every later call. Here: the same mixed call twice then a clean call all answer; each
zeta in {1, 1 + eps, 1 + 2 eps} is within the solver's own bound of the 30-digit mpmath
truth through `solve_impacts`, `solve_impact` and `prepare` alike; zeta just below 1
(1 - 1e-16, 1 - eps, 1 - 2 eps: the theory's end of contact at s_end = pi / omega_d
~ 2e8, beyond `S_END_MAX`) is refused in one line by every path, as the truth refuses it,
before any work; and no compiled function under a parallel loop can raise.
"""

from __future__ import annotations

import math

import mpmath
import numba
import numpy as np
import pytest

from reference_impl import PowerLaw, solve_impacts
from reference_impl.errors import HCVInputError
from reference_impl.exact import _law_batch, batch
from reference_impl.exact._truth import solve_impact_mp
from reference_impl.exact.prepared import prepare
from reference_impl.exact.solve import solve_impact
from verification.assertions import assert_close, assert_less, assert_true

_EPS = float(np.finfo(float).eps)
# Critical damping and the next floats above it (1 + 1e-16 is 1.0 itself).
_AT_OR_ABOVE = (1.0, 1.0 + _EPS, 1.0 + 2.0 * _EPS)
# The floats just below 1: 1 - 1e-16 is 1 - eps/2, the largest float below 1.
_JUST_BELOW = (1.0 - 1e-16, 1.0 - _EPS, 1.0 - 2.0 * _EPS)
# Ordinary damping ratios around them: the Gauss-Jacobi batch (< 0.9), its one-by-one
# path (0.95) and the overdamped tail (2).
_ORDINARY = (0.0, 0.1, 0.5, 0.95, 2.0)
# n = 1.5 (beta = 1/3 > 0: the overdamped tail has a finite time) and Hertz (n = 2.5:
# the body never returns to q = 0 at zeta >= 1, contact time inf).
_POTENTIALS = (PowerLaw(1.0e4, 0.5), PowerLaw(1.0e9, 1.5))
_M, _V0 = 0.01, 1.0
# The truth's digits (`solve_impact_mp`): 30, far below the solver's bounds (~1e-14 relative).
_DPS = 30
# The peak overlap and the zero-force restitution are closed forms of zeta (exp, log1p,
# sqrt, a power 2/n: each correctly rounded, <= 1 ulp, on arguments within a few ulps):
# a few ulps, far inside 1e-14.
_CLOSED_FORM_RTOL = 1e-14


def _mixed_zetas() -> np.ndarray:
    return np.array([*_ORDINARY, *_AT_OR_ABOVE, 0.3, 1.0, 0.0, 1.0 + _EPS] * 3)


def _check_row(got: dict, i: int, sol, call: str) -> None:
    """Row i of `solve_impacts`'s arrays is ``sol`` (`solve_impact`), bit for bit."""
    for key, arr in got.items():
        want = getattr(sol, key)
        assert_true(
            np.array_equal(arr[i], want),
            got=f"{key} = {arr[i]!r}",
            should=f"{want!r}, solve_impact's value bit for bit",
            claim="solve_impacts",
            call=call,
        )


# A sum of powers: no Gauss-Jacobi batch, every impact by `prepare` (its compiled family call).
_SUM = PowerLaw(1.0e4, 0.5) + PowerLaw(1.0e6, 0.8)


@pytest.mark.parametrize("pot", [*_POTENTIALS, _SUM], ids=repr)
def test_mixed_call_twice_then_a_clean_call_all_answer(pot):
    """Fails on main: the second call raised SystemError (and every later one)."""
    z = _mixed_zetas()
    v = np.linspace(0.5, 2.0, z.size)
    for attempt in ("first", "second"):
        got = solve_impacts(pot, _M, v, z)
        call = f"solve_impacts({pot!r}, {_M}, v, mixed zetas), {attempt} call"
        for i in np.flatnonzero(z >= 0.9):  # the one-by-one path: solve_impact bit for bit
            _check_row(got, i, solve_impact(pot, _M, float(v[i]), float(z[i])), call)
    # One zeta alone, then the scalar: the same kernels, a single distinct zeta.
    for zs in (np.array([1.0]), np.array([1.0]), 1.0):
        got = solve_impacts(pot, _M, np.array([_V0]), zs)
        _check_row(got, 0, solve_impact(pot, _M, _V0, 1.0), f"solve_impacts(..., {zs!r})")
    clean = solve_impacts(pot, _M, np.array([1.0, 2.0]), np.array([0.1, 0.5]))
    for i, (vi, zi) in enumerate(((1.0, 0.1), (2.0, 0.5))):
        sol = solve_impact(pot, _M, vi, zi)
        # the Gauss-Jacobi batch agrees with solve_impact to round-off (module docstring)
        assert_close(
            clean["contact_time"][i],
            sol.contact_time,
            rtol=1e-13,
            claim="solve_impacts",
            call=f"clean call after the mixed ones, zeta = {zi}",
        )


@pytest.mark.mpmath
@pytest.mark.parametrize("pot", _POTENTIALS, ids=repr)
def test_at_and_above_critical_within_bound_of_truth(pot):
    z = np.array([*_AT_OR_ABOVE, 0.2, *_AT_OR_ABOVE[::-1]])
    got = solve_impacts(pot, _M, _V0, z)
    solver = prepare(pot, _M)
    for i, zeta in enumerate(_AT_OR_ABOVE):
        call = f"solve_impacts({pot!r}, {_M}, {_V0}, zeta = {zeta!r} in a mix)"
        sol = solve_impact(pot, _M, _V0, zeta)
        _check_row(got, i, sol, call)
        _check_row(got, z.size - 1 - i, sol, call)
        _check_row({k: np.array([getattr(solver(_V0, zeta), k)]) for k in got}, 0, sol, "prepare")
        truth = solve_impact_mp(pot, _M, _V0, zeta, dps=_DPS)
        pairs = [("contact_time_zero_force", sol.quadrature_error_zero_force)]
        if mpmath.isfinite(truth["contact_time"]):
            pairs.append(("contact_time", sol.quadrature_error))
        else:
            assert_true(
                sol.contact_time == math.inf,
                got=repr(sol.contact_time),
                should="inf (the truth never returns to q = 0)",
                claim="impl",
                call=call,
            )
        for key, bound in pairs:
            err = float(abs(mpmath.mpf(getattr(sol, key)) - truth[key]))
            assert_less(err, bound, claim="impl", call=call, what=f"|{key} - truth|")
        for key in ("max_penetration", "restitution_zero_force"):
            assert_close(
                getattr(sol, key),
                float(truth[key]),
                rtol=_CLOSED_FORM_RTOL,
                claim="impl",
                call=call,
            )
        assert_true(
            sol.restitution == 0.0 and float(truth["restitution"]) == 0.0,
            got=f"restitution {sol.restitution!r} (truth {truth['restitution']})",
            should="0 (no return to q = 0 at zeta >= 1)",
            claim="impl",
            call=call,
        )


def _one_line_refusal(fn, zeta: float, call: str) -> None:
    with pytest.raises(HCVInputError) as exc:
        fn()
    msg = str(exc.value)
    assert_true(
        "\n" not in msg and repr(zeta) in msg and "too close to 1" in msg,
        got=repr(msg),
        should=f"one line naming zeta = {zeta!r} as too close to 1",
        claim="impl",
        call=call,
    )


@pytest.mark.parametrize("zeta", _JUST_BELOW)
def test_just_below_critical_refused_in_one_line_by_every_path(zeta):
    """s_end = pi / omega_d ~ 2e8 lies beyond S_END_MAX (the documented range of
    `solve_impact`, which the truth shares): refused by every path, the batch before any
    compiled work, and the next call answers."""
    pot = _POTENTIALS[1]
    z = np.array([0.1, 1.0, zeta, 2.0])
    _one_line_refusal(lambda: solve_impacts(pot, _M, _V0, z), zeta, "solve_impacts, a mix")
    _one_line_refusal(lambda: solve_impact(pot, _M, _V0, zeta), zeta, "solve_impact")
    _one_line_refusal(lambda: prepare(pot, _M)(_V0, zeta), zeta, "prepare(...)(v0, zeta)")
    with pytest.raises(HCVInputError, match="too close to 1"):
        solve_impact_mp(pot, _M, _V0, zeta, dps=_DPS)
    got = solve_impacts(pot, _M, _V0, np.array([0.1, 1.0]))
    assert_true(
        bool(np.all(np.isfinite(got["max_penetration"]))),
        got=repr(got["max_penetration"]),
        should="finite overlaps (the call after a refusal answers)",
        claim="solve_impacts",
        call="solve_impacts after a refused mix",
    )


def test_batch_refuses_zeta_above_its_range_before_work():
    pot = _POTENTIALS[1]
    with pytest.raises(HCVInputError, match="outside"):
        solve_impacts(pot, _M, _V0, np.array([0.5, 1.0e3 * (1.0 + _EPS)]))


def test_universal_law_at_critical_through_the_law_argument():
    pot = _POTENTIALS[0]
    got = solve_impacts(pot, _M, np.array([0.5, 1.0]), law={"law": "universal", "zeta": 1.0})
    _check_row(got, 1, solve_impact(pot, _M, 1.0, 1.0), "solve_impacts(law=universal, 1)")


def _compiled_callees(disp, seen: dict) -> None:
    """Every numba dispatcher ``disp`` calls, by the global names its Python code reads
    (recursively; a `specialise` copy's bound functions are its globals)."""
    code = disp.py_func.__code__
    names = set(code.co_names)
    for const in code.co_consts:  # nested code objects (comprehensions, closures)
        if hasattr(const, "co_names"):
            names |= set(const.co_names)
    for name in names:
        obj = disp.py_func.__globals__.get(name)
        if isinstance(obj, numba.core.registry.CPUDispatcher) and obj not in seen.values():
            seen[f"{obj.py_func.__module__}.{obj.py_func.__name__}"] = obj
            _compiled_callees(obj, seen)


def test_no_compiled_function_under_a_parallel_loop_can_raise_on_division():
    """error_model "numpy" on every parallel kernel and everything it calls: a division by
    zero gives inf or NaN (refused by the status tests), never an exception inside the
    prange loop (which poisoned every later call, issue 36)."""
    kernels = [
        obj
        for mod in (batch, _law_batch)
        for obj in vars(mod).values()
        if isinstance(obj, numba.core.registry.CPUDispatcher) and obj.targetoptions.get("parallel")
    ]
    assert_true(
        len(kernels) == 4,
        got=f"{len(kernels)} parallel kernels",
        should="4 (_gj_batch, _count_invalid, _power_law_fill, _solve_rows)",
        claim="solve_impacts",
        call="batch and _law_batch",
    )
    for kernel in kernels:
        seen = {kernel.py_func.__name__: kernel}
        _compiled_callees(kernel, seen)
        for name, fn in seen.items():
            assert_true(
                fn.targetoptions.get("error_model") == "numpy",
                got=f"{name} compiled with error_model {fn.targetoptions.get('error_model')!r}",
                should="'numpy' (no exception inside a parallel loop)",
                claim="solve_impacts",
                call=f"callees of {kernel.py_func.__name__}",
            )
