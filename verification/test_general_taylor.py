"""The Taylor general-law kernel (`reference_impl.exact._general_taylor`, issue 27 goal 3).

It is checked through `solve_law_impact` (whose kernel it is, its fields formed in the
same compiled call) against the 30-digit truth (`_general_law_mp`) within its own
bounds, against the GBS kernel (its row formed by `_general_fields.form`, as
`solve_law_impact` forms another kernel's row) on many generated laws, and for its
hand-over to the GBS kernel outside its domain.
"""

from __future__ import annotations

import functools
import types

import numpy as np
import pytest
from hypothesis import Phase, example, given, settings

from reference_impl import PowerLaw
from reference_impl.exact import general_law as gl
from reference_impl.exact._general_fields import FAILED, FORMED, form
from reference_impl.exact._general_kernel import solve as gbs_kernel
from reference_impl.exact._general_law_mp import solve_law_impact_mp
from reference_impl.exact._general_taylor import solve as taylor_kernel
from reference_impl.exact._general_taylor import solve_taylor
from reference_impl.exact._validate import _validated_top
from reference_impl.potentials import SumPotential
from reference_impl.theory.laws import LAWS, law_from_dict
from verification.assertions import assert_close, assert_less, assert_true
from verification.strategies import law_cases

CALL = "solve_law_impact (Taylor kernel)"
# Truth runs cost 2-4 s each: two derandomised draws per law.
TRUTH_EXAMPLES = 2
# q_max = L rho^N and U'(q_max) = sum k q_max^p are polynomials of degree <= N p <= 6 in
# the state (rho, W) (N = 2 with p <= 3, N = 4 for the universal law on Hertz): their
# relative error is at most this many times the state's, which error_restitution bounds.
STATE_TO_OUTPUT = 8.0
# Against the GBS kernel, for outputs without a bound of their own: the goal of issue 18
# (1e-12), which both kernels meet (measured: GBS ~1e-14, Taylor ~3e-16).
GOAL_RTOL = 1e-12
_BOUNDED = (
    ("contact_time", "error_time"),
    ("contact_time_zero_force", "error_time"),
    ("time_of_max_penetration", "error_time"),
    ("restitution", "error_restitution"),
    ("restitution_zero_force", "error_restitution"),
)
_UNBOUNDED = ("max_penetration", "max_force", "peak_force")
# Draws that the random profile once found, run every time (Phase.explicit): a zero-force
# end at a tiny overlap 5e-10 s before the exit (k q^3, C = c0 + c1 q, c0 ~ 0), which the
# truth's exit step missed (`test_general_law_zf_exit` holds more such cases). law_cases
# draws a weight near 0 for both c0 and c1 rarely; changing its draws would move every
# derandomised draw of the law tests, so the case is named here instead.
_EXPLICIT = {
    "polynomial": (
        PowerLaw(56796532.80788986, 3.0),
        0.0015724852401864868,
        0.010952265788383615,
        {"law": "polynomial", "c": [3.6e-291, 1.5393784782598136e-13]},
    ),
}


# The Taylor kernel is `solve_law_impact`'s own: its fields are formed in the kernel's
# compiled call (`_general_fields.solve_formed`), so the module name `_compiled_solve` that
# a first version of this module rebound is no longer read, and the "GBS" side of
# `test_taylor_agrees_with_gbs_kernel` was the Taylor kernel too (a test that could not
# fail). The GBS kernel's side is now its own row, formed as `solve_law_impact` forms a row.
solve_taylor_law = gl.solve_law_impact


def _gbs_solution(pot, m, v0, law):
    """The GBS kernel's fields of one impact (a namespace of `LawImpactSolution`'s names),
    or None where it does not finish (`_general_fields.FAILED`)."""
    args = _kernel_args(pot, m, v0, law)
    f = form(gbs_kernel(*args), v0, args[1])
    if f[0] == FAILED:
        return None
    return types.SimpleNamespace(**dict(zip(FORMED, f[1:], strict=True)))


def _key(pot):
    terms = pot.terms if isinstance(pot, SumPotential) else (pot,)
    return tuple((t.k, t.p) for t in terms)


@functools.cache
def _truth(pot_key, m, v0, law_key):
    terms = [PowerLaw(k, p) for k, p in pot_key]
    pot = terms[0] if len(terms) == 1 else SumPotential(*terms)
    return solve_law_impact_mp(pot, m, v0, dict(law_key))


def _law_key(law):
    return tuple((k, tuple(v) if isinstance(v, list) else v) for k, v in law.items())


@pytest.mark.parametrize("name", [n for n in LAWS if n != "none"])
def test_taylor_against_30_digit_truth(name):
    """Every output within the solver's own bound of the 30-digit truth."""

    # No shrinking: each truth run costs seconds, and the failing draw is printed as is.
    @settings(max_examples=TRUTH_EXAMPLES, phases=(Phase.explicit, Phase.generate))
    @given(law_cases(name))
    def run(case):
        _check_against_truth(*case)

    if name in _EXPLICIT:
        run = example(_EXPLICIT[name])(run)
    run()


def _check_against_truth(pot, m, v0, law):
    sol = solve_taylor_law(pot, m, v0, law)
    call = f"{CALL}({pot!r}, m={m!r}, v0={v0!r}, {law})"
    assert_true(
        sol.returns_to_q0,
        got=f"no return for {law} (v0 = {v0})",
        should="a return (law_cases draws only returning bodies)",
        claim="general-law",
        call=call,
    )
    tr = _truth(_key(pot), m, v0, _law_key(law))
    for key, bound in _BOUNDED:
        err = abs(getattr(sol, key) - float(tr[key]))
        assert_less(err, getattr(sol, bound), claim="general-law", call=call, what=key)
    for key in _UNBOUNDED:
        assert_close(
            getattr(sol, key),
            float(tr[key]),
            rtol=STATE_TO_OUTPUT * sol.error_restitution,
            claim="general-law",
            call=call,
        )


@pytest.mark.parametrize("name", [n for n in LAWS if n != "none"])
def test_taylor_agrees_with_gbs_kernel(name):
    """The two kernels agree within the sum of their bounds on generated laws and speeds."""

    @settings(max_examples=25, deadline=None)
    @given(law_cases(name))
    def run(case):
        pot, m, v0, law = case
        a = solve_taylor_law(pot, m, v0, law)
        b = _gbs_solution(pot, m, v0, law)
        if b is None:
            # the GBS kernel's own failure (found: Hunt-Crossley on Hooke + Hertz, the exit
            # of a pulling force): the truth judges this case
            _check_against_truth(pot, m, v0, law)
            return
        call = f"{CALL}({pot!r}, m={m!r}, v0={v0!r}, {law})"
        assert_true(
            a.returns_to_q0 == b.returns_to_q0,
            got=f"returns {a.returns_to_q0} (Taylor), {b.returns_to_q0} (GBS)",
            should="the same",
            claim="general-law",
            call=call,
        )
        for key, bound in _BOUNDED:
            ga, gb = getattr(a, key), getattr(b, key)
            if ga == gb:  # inf == inf for a body that does not return
                continue
            tol = getattr(a, bound) + getattr(b, bound)
            assert_less(abs(ga - gb), tol, claim="general-law", call=call, what=key)
        for key in _UNBOUNDED:
            assert_close(
                getattr(a, key), getattr(b, key), rtol=GOAL_RTOL, claim="general-law", call=call
            )

    run()


def test_taylor_where_the_gbs_kernel_fails():
    """A generated case the GBS kernel does not finish (Hunt-Crossley on Hooke + Hertz,
    a force that pulls just before q = 0): the Taylor kernel meets the truth."""
    pot = PowerLaw(499742563.91804487, 1.0) + PowerLaw(7695668.303783785, 1.5)
    _check_against_truth(pot, 1.0, 1.0, {"law": "hunt-crossley", "alpha": 0.24999742544610493})


def _kernel_args(pot, m, v0, law):
    dl = law_from_dict(law)
    cs, es, sc = gl._law_arrays(dl, m, pot)
    ks, ps = gl._power_terms(pot)
    return (v0, _validated_top(pot, 0.5 * m * v0 * v0), ks, ps, cs, es, sc)


@pytest.mark.parametrize(
    "pot, m, v0, law",
    [
        # exponent 1.3 = 13/10: no q = L rho^N with N <= 8 makes it a polynomial
        (PowerLaw(1e9, 1.3), 0.01, 1.0, {"law": "linear", "c": 20.0}),
        # an overdamped linear dashpot on Hooke: the body creeps back and never returns
        (PowerLaw(1e4, 1.0), 0.01, 1.0, {"law": "linear", "c": 60.0}),
        # the universal law on a sum of power laws: C is not a power series in rho
        (PowerLaw(1e6, 1.0) + PowerLaw(1e9, 1.5), 0.01, 1.0, {"law": "universal", "zeta": 0.2}),
        # found by a sweep: an overdamped viscoelastic law on Hooke (C = A k, 1.2 x critical)
        # creeps back without return; a first version took a root of rho at round-off level
        # for an exit
        (
            PowerLaw(1816163.7683535544, 1.0),
            0.02830238853730305,
            1.056828172301165,
            {"law": "viscoelastic", "A": 0.00029715663187065343},
        ),
        # found by a sweep: a near-critical linear dashpot on Hooke + Hertz returns after a
        # long creep (39 Taylor steps), over which the error in rho integrated into T
        # outgrew the summed local estimates (5e-14 s against 4e-15 s)
        (
            PowerLaw(1037102.2586584735, 1.0) + PowerLaw(149486.880525022, 1.5),
            0.04563673867883634,
            0.14735149485274338,
            {"law": "linear", "c": 430.15542624527825},
        ),
    ],
)
def test_taylor_hands_over_outside_its_domain(pot, m, v0, law):
    """Outside its domain the Taylor kernel declines and `solve` returns the GBS kernel's result."""
    args = _kernel_args(pot, m, v0, law)
    out = np.full(13, np.nan)
    call = f"solve_taylor({pot!r}, {law})"
    assert_true(
        solve_taylor(*args, out) == 1,
        got="a Taylor result",
        should="a hand-over (status 1)",
        claim="general-law",
        call=call,
    )
    assert_true(
        np.array_equal(taylor_kernel(*args), gbs_kernel(*args), equal_nan=True),
        got="a result other than the GBS kernel's",
        should="the GBS kernel's, bit for bit",
        claim="general-law",
        call=call,
    )


# Found by `test_taylor_agrees_with_gbs_kernel` once its GBS side was the GBS kernel
# (2000 random draws a law: 2 power, 5 polynomial, 3 viscoelastic cases outside the summed
# bounds), judged here by the 30-digit truth. The Taylor kernel's (fixed): a negligible
# constant term c0 of C = c0 + c1 q on U' = k q^2 sets j0 = 0, so the zero-force function
# at the exit sample is c0 W + rho (f + c1 W) with rho = -5.6e-17 (the exit root's
# round-off), read > 0: the crossing before the exit was missed and the zero-force end put
# at the exit (1.4e-5 s off, 4.5e10 x its bound). Fails before the fix for c0 = 1.3e-36,
# 1e-20 and 1.2e-309 (subnormal); the Hertz case (rho^2 and rho^3 terms next, whose sign
# the round-off does not flip) guards the same class on N = 2.
_Q2 = (PowerLaw(10000000000.0, 2.0), 0.4198101044567141, 0.07010714804177136)


@pytest.mark.parametrize(
    "pot, m, v0, c",
    [
        (*_Q2, [1.257595069969804e-36, 143375.46932818808]),
        (*_Q2, [1e-20, 143375.46932818808]),
        (*_Q2, [1.2e-309, 143375.46932818808]),
        (PowerLaw(1e10, 1.5), 0.4, 0.5, [1e-30, 1e6]),
    ],
)
def test_taylor_zero_force_end_with_a_negligible_constant_damping(pot, m, v0, c):
    _check_against_truth(pot, m, v0, {"law": "polynomial", "c": c})


# The GBS kernel's (fixed): its last phase-2 step ended at q / |w| / 10 from q = 0, a branch
# point of q(t) (C ~ q^1.5; U' ~ q^1.5 on Hertz), where its error estimate said 5e-15 and the
# error of w was 1.6e-12 (restitution 1.8 x its bound); now 2e-14 off. The viscoelastic case,
# found by a sweep of law_cases against the Taylor kernel, was 8.2 x its bound (now 0.02 x).
# Both fail on main (the first was a strict xfail there; the second checked by stash).
@pytest.mark.parametrize(
    "pot, m, v0, law",
    [
        (
            PowerLaw(10000.0, 2.0),
            0.0391126800133978,
            1.0,
            {"law": "power", "c": 21.930700561278762, "exponent": 1.5},
        ),
        (
            PowerLaw(9131565.950810451, 1.5),
            0.07088710277930858,
            0.01374742299270142,
            {"law": "viscoelastic", "A": 0.0001149013062637917},
        ),
    ],
)
def test_gbs_restitution_within_its_bound(pot, m, v0, law):
    sol = _gbs_solution(pot, m, v0, law)
    tr = _truth(_key(pot), m, v0, _law_key(law))
    call = f"GBS kernel ({pot!r}, m={m!r}, v0={v0!r}, {law})"
    for key, bound in _BOUNDED:
        err = abs(getattr(sol, key) - float(tr[key]))
        assert_less(err, getattr(sol, bound), claim="general-law", call=call, what=key)
