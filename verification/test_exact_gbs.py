"""The GBS kernel compiled on a term table (issue 38; `reference_impl.exact._general_rows`).

A general law on a potential that is no sum of power laws but has a term table of power
and cap rows (sphere, ellipsoid, their sums) ran the GBS kernel in plain Python around
the potential's numpy methods (~60 ms an impact); it now runs the same algorithm
compiled on the table. The Python path stays (a saturating force, an expression without
a table) and is the reference here: the same algorithm, so the two differ by round-off
only, far inside the error bound each reports. The 30-digit truths of the general-law
solver take power laws only; the universal law on a cap, whose exact quadrature is an
independent truth, runs through the table path in
`verification/test_general_law.py::test_other_families_universal_against_exact`.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from reference_impl import load_scene
from reference_impl.exact import general_law as gl
from reference_impl.exact._general_rows import fc_rows, table_arrays
from reference_impl.exact._general_step import fc
from reference_impl.potentials import Ellipsoid, PowerLaw, Sphere, SumPotential
from reference_impl.potentials.saturating import SaturatingForce
from verification.assertions import assert_close, assert_less, assert_true

CALL = "solve_law_impact"
# The linear dashpot of the work-precision study (benchmarks/bench_workprecision.LAW):
# e ~ 0.8 at 1 m/s on Hertz; scaled 0.1-1x per impact as the study draws it.
_C_STUDY = 26.75
# U, U', U'' of a cap row against the family's own numpy formulas, in the same order of
# operations: a few roundings of ~1 ulp each, and numba's and numpy's pow may differ by an
# ulp, amplified by alpha + 1 <= 2 in V^(alpha+1): 1e-14 is ~50 ulps.
_ROUND_RTOL = 1e-14
# U''' against a central difference of U'' with step h = 1e-5 q: its truncation error is
# h^2 U^(5) / 6 ~ 2e-11 relative on these caps, its round-off eps U'' / h ~ 1e-11 relative.
_FD_RTOL = 1e-8


def _old(pot, m, v0, law):
    """Today's Python path: the same plan with its table dropped (the numpy force)."""
    return gl._solve_planned(gl._plan(pot, m, law)._replace(tab=None), v0)


def _agree(new, old, call):
    """New against old within the new solution's own reported bound (times, restitutions)
    and, for q_max and the peak force, within its restitution bound taken relative: both
    are state values at located events, whose relative error the kernel sums with the
    restitution's (the local error estimates of (q, w) at its scales q_E, v0)."""
    assert_true(new.returns_to_q0 == old.returns_to_q0, got=f"returns {new.returns_to_q0}",
                should=f"{old.returns_to_q0} as the Python path",
                claim="general-law table path", call=call)  # fmt: skip
    # A body that never returns has t_c = inf and e = 0 on both paths (compared exactly).
    ends = () if old.returns_to_q0 else ("contact_time", "restitution")
    for key in ends:
        assert_true(getattr(new, key) == getattr(old, key), got=f"{getattr(new, key)!r}",
                    should=f"{getattr(old, key)!r}", claim="general-law table path",
                    call=f"{call}.{key}")  # fmt: skip
    times = ("contact_time_zero_force", "time_of_max_penetration")
    for key in times + (() if ends else ("contact_time",)):
        assert_close(getattr(new, key), getattr(old, key), rtol=0.0, atol=new.error_time,
                     claim="general-law table path", call=f"{call}.{key}")  # fmt: skip
    for key in ("restitution_zero_force",) + (() if ends else ("restitution",)):
        assert_close(getattr(new, key), getattr(old, key), rtol=0.0, atol=new.error_restitution,
                     claim="general-law table path", call=f"{call}.{key}")  # fmt: skip
    for key in ("max_penetration", "peak_force"):
        assert_close(getattr(new, key), getattr(old, key), rtol=new.error_restitution,
                     claim="general-law table path", call=f"{call}.{key}")  # fmt: skip


def test_caps_take_the_table_path():
    """Sphere, ellipsoid and a cap plus a power law plan the compiled table path; a
    saturating force (no compiled U near 0) keeps the Python one; a power law keeps its own."""
    m, law = 0.05, {"law": "linear", "c": 10.0}
    cases = [
        (Sphere(0.01, 1e8, 0.5), True),
        (Ellipsoid(0.01, 0.02, 0.015, 1e8, 0.7), True),
        (SumPotential(Sphere(0.01, 1e8, 0.5), PowerLaw(1e6, 1.5)), True),
        (SaturatingForce(10.0, 1e-3), False),
        (PowerLaw(1e6, 1.5), False),
    ]
    for pot, tabled in cases:
        plan = gl._plan(pot, m, law)
        assert_true((plan.tab is not None) == tabled, got=f"tab = {plan.tab is not None}",
                    should=f"{tabled}", claim="general-law table path",
                    call=f"_plan({pot!r})")  # fmt: skip


@pytest.mark.parametrize("pot", [Sphere(0.01, 1e8, 0.5), Ellipsoid(0.01, 0.02, 0.015, 1e8, 0.3)])
def test_fc_rows_matches_the_family(pot):
    """U, U', U'' of the table against the family's methods; U''' (C' of the
    viscoelastic law C = A U'') against a central difference of U''."""
    rows, lim = table_arrays(pot)
    A = 1e-6
    sc = np.array([0.05, 0.0, A, 0.0, 0.0, 0.0, 0.0])
    none = np.zeros(0)
    for q in (1e-6, 1e-4, 3e-3, 0.01, 0.019):
        arr = np.array([q])
        want = (pot._U(arr)[0], pot._dU(arr)[0], pot._d2U(arr)[0])
        for how, f in (("compiled", fc_rows), ("dispatch from Python", fc)):
            U, dU, d2U, C, dC = f(q, True, rows, lim, none, none, sc)
            for name, got, ref in zip(("U", "U'", "U''"), (U, dU, d2U), want, strict=True):
                assert_close(got, ref, rtol=_ROUND_RTOL, claim="general-law table path",
                             call=f"fc_rows {how} {name}({q}) of {pot!r}")  # fmt: skip
        h = 1e-5 * q
        d3 = (pot._d2U(np.array([q + h]))[0] - pot._d2U(np.array([q - h]))[0]) / (2 * h)
        assert_close(dC / A, d3, rtol=_FD_RTOL, claim="general-law table path",
                     call=f"fc_rows U'''({q}) of {pot!r}")  # fmt: skip


def test_sphere_linear_dashpot_random_impacts_agree_with_python_path():
    """Random impacts of the study's sphere under the linear dashpot: the compiled table
    path against the Python path, each output within the new solution's own bound."""
    sc = load_scene("sphere-damped")
    rng = np.random.default_rng(38)
    # Speeds up to 5 m/s: the cap holds at most 0.57 J (q = 2R), 5.9 m/s for this mass.
    v0s = 10.0 ** rng.uniform(-2.0, math.log10(5.0), 12)
    cs = _C_STUDY * 10.0 ** rng.uniform(-1.0, 0.0, 12)
    worst = 0.0
    for v0, c in zip(v0s, cs, strict=True):
        law = {"law": "linear", "c": float(c)}
        call = f"{CALL}(sphere-damped, v0={v0!r}, {law})"
        new = gl.solve_law_impact(sc.potential, sc.mass, float(v0), law)
        old = _old(sc.potential, sc.mass, float(v0), law)
        _agree(new, old, call)
        if old.returns_to_q0:
            worst = max(worst, abs(new.contact_time - old.contact_time) / new.error_time)
    # The paths differ by round-off, not by the method's error: far inside the bound
    # (measured: at most 0.05 of the two bounds' sum over 300 such impacts of the study), so the check above is not vacuous by
    # a bound that only a gross difference could reach.
    assert_less(worst, 0.5, claim="general-law table path",
                call=f"{CALL}(sphere-damped) |t_c new - old| / error_time")  # fmt: skip


@pytest.mark.parametrize(
    "law",
    [
        {"law": "universal", "zeta": 0.4},
        {"law": "hunt-crossley", "alpha": 0.3},
        {"law": "viscoelastic", "A": 2e-5},
        {"law": "power", "c": 40.0, "exponent": 0.5},
    ],
)
@pytest.mark.parametrize("scene", ["sphere", "paper-ellipsoid-damped"])
def test_other_laws_agree_with_python_path(scene, law):
    """Every kind of term of the force function (the zeta law's U'/sqrt(2U), alpha U',
    A U'' with its U''', a power of q) on both caps: table path against Python path."""
    sc = load_scene(scene)
    for v0 in sc.velocities[:2]:
        call = f"{CALL}({scene}, v0={v0!r}, {law})"
        _agree(gl.solve_law_impact(sc.potential, sc.mass, v0, law),
               _old(sc.potential, sc.mass, v0, law), call)  # fmt: skip
