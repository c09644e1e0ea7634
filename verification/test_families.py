"""Tool tests of the family registry: a new potential family is one class plus one
registration line, and the scene parser, the solver and the scene round trip pick it up.
"""

from __future__ import annotations

import numpy as np
import pytest

from reference_impl.exact.solve import solve_impact
from reference_impl.potentials import (
    FAMILIES,
    Expression,
    Potential,
    PowerLaw,
    register_family,
    unregister_family,
)
from reference_impl.potentials._terms import power_row
from reference_impl.scenes import load_scene, parse_scene, scene_from_dict
from reference_impl.scenes._catalogue import catalogue_rows
from reference_impl.scenes._scene import potential_to_dict
from reference_impl.tasks import solve_scene
from verification.assertions import assert_close, assert_true


class QuarticWell(Potential):
    """U = k q^4 / 4 (force k q^3): the same law as PowerLaw(k, 3), written as a family."""

    family = "test-quartic"
    scene_keys = (("k",), ())
    label = "test family U' = k q^3"
    leading_exponent = 4.0

    def __init__(self, k: float):
        self.k = float(k)
        self.leading_coefficient = self.k / 4.0

    def _U(self, q):
        return self.k * q**4 / 4

    def _dU(self, q):
        return self.k * q**3

    def _d2U(self, q):
        return 3 * self.k * q**2

    def params(self):
        return {"k": self.k}


@pytest.fixture
def quartic():
    register_family(QuarticWell)  # the one registration line
    yield QuarticWell
    unregister_family(QuarticWell.family)


_SCENE = """
name = "quartic"
mass = 0.1
velocities = [0.5, 2.0]
[potential]
family = "test-quartic"
k = 3.0
[damping]
law = "universal"
zeta = 0.2
"""


def test_a_family_defined_in_a_test_is_a_scene_family(quartic):
    scene = parse_scene(_SCENE, "<test>")
    assert isinstance(scene.potential, QuarticWell)
    again = scene_from_dict({k: v for k, v in scene.to_dict().items() if k != "source"})
    assert again.potential.params() == scene.potential.params()
    rows = solve_scene(scene)
    for row in rows:
        ref = solve_impact(PowerLaw(3.0, 3.0), 0.1, row["v0"], 0.2)
        # Same law by two routes (general quadrature path vs the power-law path): both are
        # accurate to ~1e-15 relative; 1e-12 leaves room for the general path's bound.
        assert_close(
            row["contact_time"],
            ref.contact_time,
            rtol=1e-12,
            claim="tool",
            call=f"solve_scene(test-quartic, v0={row['v0']})",
        )
        assert_close(
            row["restitution"],
            ref.restitution,
            rtol=1e-12,
            claim="tool",
            call=f"solve_scene(test-quartic, v0={row['v0']})",
        )


def test_an_unregistered_family_is_refused_naming_the_known_ones():
    from reference_impl.errors import SceneError

    with pytest.raises(SceneError, match="test-quartic.*is not one of.*'power'"):
        parse_scene(_SCENE, "<test>")


def _catalogue_example(family: str):
    """The potential of the first catalogue scene of ``family`` (None when it has none)."""
    for row in catalogue_rows():
        if row["family"] == family:
            return load_scene(row["name"]).potential
    return None


# One example per registered family, read from the scene catalogue (a new family is
# tested once it has a scene there, and fails below until it has one), plus a sum whose
# terms are of two families.
_ROUND_TRIP = [pytest.param(_catalogue_example(name), id=name) for name in sorted(FAMILIES)] + [
    pytest.param(PowerLaw(1.0, 1.0) + Expression("q**3"), id="sum of power and expression")
]


@pytest.mark.parametrize("pot", _ROUND_TRIP)
def test_every_family_round_trips_through_its_scene_table(pot):
    assert pot is not None, (
        "got no catalogue scene of this family, should be one in reference_impl/scenes/ "
        "[tool, registered family]"
    )
    table = potential_to_dict(pot)
    assert table["family"] in FAMILIES and FAMILIES[table["family"]].label
    scene = scene_from_dict(
        {"name": "rt", "mass": 1.0, "velocities": [0.1], "kind": "impact", "potential": table}
    )
    q = np.array([1e-4, 1e-3])
    assert_close(scene.potential.U(q), pot.U(q), rtol=0.0, claim="tool", call=f"round trip {table}")
    assert_true(
        potential_to_dict(scene.potential) == table,
        got=potential_to_dict(scene.potential),
        should=table,
        claim="tool",
        call="potential_to_dict round trip",
    )


class QuarticTable(QuarticWell):
    """QuarticWell with its term table (contract item 8): one row, k q^4 / 4."""

    def _term_rows(self):
        return [power_row(self.k, 4.0, 3.0)]


def test_a_family_with_a_term_table_runs_in_both_compiled_kernels():
    """The term-table hook is the one place for compiled speed: with it a family defined
    here gets the exact solver's table kernels and the Verlet lane kernel, with no line
    in exact/ or integrators/; without it (QuarticWell) neither."""
    from reference_impl.exact._nodes import node_kernel, substitution_order
    from reference_impl.integrators.verlet import SCENE_WALLS, LaneBatch, kernel_terms, run_lanes

    plain, tabled, law = QuarticWell(3.0), QuarticTable(3.0), PowerLaw(3.0, 3.0)
    assert_true(
        kernel_terms(plain) is None and node_kernel(plain) is None,
        got="a compiled kernel",
        should="none without a table",
        claim="tool",
        call="QuarticWell",
    )
    k = node_kernel(tabled)
    assert_true(
        k is not None and k.terms and substitution_order(tabled, 8) == substitution_order(law, 8),
        got=repr(k),
        should="the table kernels, with the power law's substitution order",
        claim="tool",
        call="node_kernel(QuarticTable)",
    )
    dt = np.array([0.1, 0.5, 1.0, 2.0])
    b = LaneBatch(dt=dt, y0=0.0, v0=1.0, gap=0.0, e_limit=50.0, max_steps=3_000)
    a, t = run_lanes(law, 1.0, SCENE_WALLS, b), run_lanes(tabled, 1.0, SCENE_WALLS, b)
    assert_true(
        t.engine == "numba" and np.array_equal(a.e_max, t.e_max, equal_nan=True),
        got=f"{t.engine} {t.e_max}",
        should=f"numba {a.e_max} (the same table as PowerLaw(3, 3))",
        claim="tool",
        call="run_lanes(QuarticTable)",
    )
    for v0 in (0.5, 2.0):
        got, ref = solve_impact(tabled, 0.1, v0, 0.2), solve_impact(law, 0.1, v0, 0.2)
        # The same compiled rules and node loop; only the inverse of U at the turning
        # point (numeric here, closed form for PowerLaw) and the warm start differ.
        assert_close(
            got.contact_time,
            ref.contact_time,
            rtol=1e-14,
            claim="tool",
            call=f"solve_impact(QuarticTable, v0={v0})",
        )
        assert_close(
            got.restitution,
            ref.restitution,
            rtol=1e-14,
            claim="tool",
            call=f"solve_impact(QuarticTable, v0={v0})",
        )
