"""An exact solution depends on its own inputs only, never on the calls made before.

`_validate._validated_top` caches, per potential object, the largest energy whose
monotonicity it checked. It returned that energy's turning point to a lower energy too,
and the solvers use the value as a bracket and as the scale of their error control: a
general-law impact then changed with the speeds solved before on the same object
(Hertz + linear dashpot at 1e-4 m/s: error_time 1.2e-15 fresh, 8.0e-13 after 1 m/s), and
`solve_impact` on a sphere or ellipsoid in its last bits. Each case here solves a speed
on a fresh object and on one that solved faster and slower speeds first, and compares
every float field bit for bit (the cache may speed up the check only).
"""

from __future__ import annotations

import dataclasses

import pytest

from reference_impl import PowerLaw
from reference_impl.exact.general_law import prepare_law, solve_law_impact
from reference_impl.exact.prepared import prepare
from reference_impl.exact.solve import solve_impact
from reference_impl.potentials import Ellipsoid, SaturatingForce, Sphere, SumPotential
from verification.assertions import assert_true

# Speeds solved first (m/s): faster ones (a cached energy above the one compared) and a
# slower one; then the compared speeds, below all of the faster ones.
_BEFORE = (3.0, 1.0, 1e-5)
_SPEEDS = (1e-4, 1e-3)

_POTENTIALS = {
    "hertz": lambda: PowerLaw(1e9, 1.5),
    "hertz+power2.5": lambda: SumPotential(PowerLaw(1e9, 1.5), PowerLaw(1e12, 2.5)),
}
_LAWS = (
    {"law": "linear", "c": 50.0},
    {"law": "hunt-crossley", "alpha": 0.37},
    {"law": "viscoelastic", "A": 1.23e-6},
    {"law": "polynomial", "c": [19.1, 1.87e6]},
)
_UNIVERSAL = {
    "hertz": lambda: PowerLaw(1e9, 1.5),
    "sphere": lambda: Sphere(0.01, 1e8, 0.5),
    "ellipsoid": lambda: Ellipsoid(0.015, 0.008, 0.008, 1e8, 0.5),
    "saturating": lambda: SaturatingForce(2.0, 3e-3),
    "hertz+power2": lambda: SumPotential(PowerLaw(1e9, 1.5), PowerLaw(1e12, 2.0)),
}
_UNIVERSAL_FIELDS = (
    "max_penetration",
    "max_force",
    "contact_time",
    "restitution",
    "contact_time_zero_force",
    "restitution_zero_force",
    "quadrature_error",
    "quadrature_error_zero_force",
)


def _same(fresh: dict, after: dict, call: str) -> None:
    for key, want in fresh.items():
        got = after[key]
        assert_true(
            repr(got) == repr(want),
            got=f"{key} = {got!r} after solving {_BEFORE} m/s on the same object",
            should=f"{want!r} (the same call on a fresh potential, bit for bit)",
            claim="exact solution depends on its inputs only",
            call=call,
        )


def _law_fields(sol) -> dict:
    return {f.name: getattr(sol, f.name) for f in dataclasses.fields(sol)}


@pytest.mark.parametrize("law", _LAWS, ids=lambda t: t["law"])
@pytest.mark.parametrize("name", sorted(_POTENTIALS))
def test_general_law_result_does_not_depend_on_earlier_calls(name, law):
    make, m = _POTENTIALS[name], 1e-3
    used, prepared = make(), None
    for v in _BEFORE:
        solve_law_impact(used, m, v, law)
    prepared = prepare_law(used, m, law)
    for v in _SPEEDS:
        fresh = _law_fields(solve_law_impact(make(), m, v, law))
        call = f"solve_law_impact({name}, {m}, {v}, {law})"
        _same(fresh, _law_fields(solve_law_impact(used, m, v, law)), call)
        _same(fresh, _law_fields(prepared(v)), f"prepare_law: {call}")


@pytest.mark.parametrize("zeta", (0.0, 0.3))
@pytest.mark.parametrize("name", sorted(_UNIVERSAL))
def test_solve_impact_result_does_not_depend_on_earlier_calls(name, zeta):
    make, m = _UNIVERSAL[name], 1e-3
    used = make()
    for v in _BEFORE:
        solve_impact(used, m, v, zeta)
    solver = prepare(used, m)
    for v in _SPEEDS:
        fresh = solve_impact(make(), m, v, zeta)
        want = {k: getattr(fresh, k) for k in _UNIVERSAL_FIELDS}
        call = f"solve_impact({name}, {m}, {v}, {zeta})"
        _same(want, {k: getattr(solve_impact(used, m, v, zeta), k) for k in want}, call)
        # prepare's power-law shortcut skips `_validated_top` below a checked energy.
        _same(want, {k: getattr(solver(v, zeta), k) for k in want}, f"prepare: {call}")
