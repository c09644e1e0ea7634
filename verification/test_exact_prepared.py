"""`prepare(potential, m)`: the repeated-impact solver equals `solve_impact` bit for bit (issue 27).

Its fast paths (one compiled call for a power law; the fused kernel without the
potential's checks for the other compiled families) and its hand-overs to
`solve_impact` (zeta >= 0.9, overdamped, split sums, bad input) must all give the
very numbers, errors and bounds of `solve_impact`. Speed: benchmarks/bench_exact.py.
"""

from __future__ import annotations

import copy
import dataclasses

import numpy as np
import pytest

from reference_impl import Expression, HCVInputError, PowerLaw, prepare, solve_impact
from reference_impl.studies.workprecision import family_scenes
from verification.assertions import assert_true

# Speeds as fractions of each scene's (a cap's scene speed is near its largest), and
# damping ratios: the Gauss-Jacobi range, its edge (0.9), the tanh-sinh and overdamped
# hand-overs.
SPEEDS = (0.05, 0.43, 1.0)
ZETAS = (0.0, 0.2, 0.61, 0.8999, 0.9, 0.97, 1.0, 1.7)


def _fields(sol) -> dict:
    out = {f.name: getattr(sol, f.name) for f in dataclasses.fields(sol)}
    out["_osc"] = dict(vars(out["_osc"]))
    out["potential"] = id(out["potential"])
    return out


def _uses_of_the_oscillator(got, want) -> dict:
    """Differences of the trajectory at five instants and of a copy's fields."""
    diff = {}
    # A copy goes through __reduce_ex__ and the instance dict, as pickling does (an
    # expression's potential itself does not pickle); taken before anything used `_osc`.
    g, w = _fields(copy.copy(got)), _fields(want)
    if g != w:
        diff["copied"] = (g, w)
    got = copy.copy(got)
    ts = np.linspace(0.0, want.contact_time, 5)
    g, w = got.state(ts), want.state(ts)
    if not all(np.array_equal(a, b, equal_nan=True) for a, b in zip(g, w, strict=True)):
        diff["state"] = (g, w)
    return diff


# A compiled family without a Gauss-Jacobi rule (its sympy form is not a sum of
# constants times powers of q): the prepared call's tanh-sinh rung.
NO_GJ = ("expression without a Gauss-Jacobi rule", "k*q**2*(1 + q/a)**0.5", 1.0e9, 1.0e-3)


def _no_gj_expression():
    return Expression(NO_GJ[1], k=NO_GJ[2], a=NO_GJ[3])


def _scenes():
    scenes = [(sc.name, sc.potential, sc.m, sc.v0) for sc in family_scenes()]
    scenes.append(("power-law p = 1 (Hooke)", PowerLaw(2.0e4, 1.0), 0.3, 2.0))
    scenes.append(("power-law p = 3", PowerLaw(1.0e12, 3.0), 0.01, 4.0))
    scenes.append((NO_GJ[0], _no_gj_expression(), 0.0041, 1.0))
    return scenes


@pytest.mark.parametrize("name,pot,m,v_scene", _scenes(), ids=[s[0] for s in _scenes()])
def test_prepare_is_solve_impact_bit_for_bit(name, pot, m, v_scene):
    solver = prepare(pot, m)
    for v0 in (f * v_scene for f in SPEEDS):
        for zeta in ZETAS:
            call = f"prepare({name}, m={m})({v0}, {zeta})"
            want = _fields(solve_impact(pot, m, v0, zeta))
            got = _fields(solver(v0, zeta))
            diff = {k: (got[k], want[k]) for k in want if got[k] != want[k]}
            if v0 == v_scene and zeta < 0.9:
                # The prepared result builds its oscillator on first use: the trajectory
                # and a copy must see the one solve_impact built.
                diff.update(
                    _uses_of_the_oscillator(solver(v0, zeta), solve_impact(pot, m, v0, zeta))
                )
            assert_true(
                not diff,
                got=f"fields differ (prepared, solve_impact): {diff}",
                should="every field identical to solve_impact's",
                claim="prepare",
                call=call,
            )


def test_prepare_takes_numpy_scalars_and_ints_as_solve_impact_does(monkeypatch):
    from reference_impl.exact import prepared

    pot = PowerLaw(1.0e9, 1.5)
    solver = prepare(pot, 0.0041)
    for v0, zeta in ((np.float64(1.3), np.float64(0.2)), (2, 0), (np.float32(0.7), 0.5)):
        want = _fields(solve_impact(pot, 0.0041, v0, zeta))
        with monkeypatch.context() as mp:  # the compiled path itself, not the hand-over
            mp.setattr(prepared, "solve_impact", None)
            got = _fields(solver(v0, zeta))
        assert_true(
            got == want and type(got["v0"]) is float,
            got=f"{got}",
            should=f"{want}, v0 a float",
            claim="prepare",
            call=f"prepare(hertz, 0.0041)({v0!r}, {zeta!r})",
        )


def test_prepare_refuses_what_solve_impact_refuses():
    pot = PowerLaw(1.0e9, 1.5)
    with pytest.raises(HCVInputError, match="m"):
        prepare(pot, -1.0)
    with pytest.raises(HCVInputError, match="potential"):
        prepare("hertz", 1.0)
    solver = prepare(pot, 0.01)
    for v0, zeta in ((-1.0, 0.2), (float("nan"), 0.2), (1.0, -0.1), (1.0, float("inf"))):
        with pytest.raises(HCVInputError) as want:
            solve_impact(pot, 0.01, v0, zeta)
        with pytest.raises(HCVInputError) as got:
            solver(v0, zeta)
        assert_true(
            str(got.value) == str(want.value),
            got=str(got.value),
            should=str(want.value),
            claim="prepare",
            call=f"prepare(hertz, 0.01)({v0}, {zeta})",
        )


def test_prepare_solves_every_compiled_family_in_its_compiled_call(monkeypatch):
    """The families whose Gauss-Jacobi rule refuses (the expression scene: a higher term
    > _GJ_RATIO_MAX times the leading one at q_max) or that have none answer from the
    prepared call's one compiled call (its tanh-sinh rung), not the Python ladder."""
    from reference_impl.exact import prepared

    scenes = {sc.name: sc for sc in family_scenes()}
    cases = [
        ("expression-damped", scenes["expression-damped"].potential, 0.0041, 1.0),
        (NO_GJ[0], _no_gj_expression(), 0.0041, 1.0),
    ]
    for name, pot, m, v0 in cases:
        solver = prepare(pot, m)
        want = _fields(solve_impact(pot, m, v0, 0.2))
        with monkeypatch.context() as mp:  # neither the Python ladder nor solve_impact
            mp.setattr(prepared.PreparedImpact, "_fused", None)
            mp.setattr(prepared, "solve_impact", None)
            try:
                got = _fields(solver(v0, 0.2))
            except TypeError as exc:  # calling None: the compiled call did not answer
                got = f"not answered by the compiled call ({exc})"
        assert_true(
            got == want,
            got=f"{got}",
            should=f"{want}, from the compiled call",
            claim="prepare",
            call=f"prepare({name}, m={m})({v0}, 0.2)",
        )
