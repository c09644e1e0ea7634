"""Tool tests of the family registry: a new potential family is one class plus one
registration line, and the scene parser, the solver and the scene round trip pick it up.
"""

from __future__ import annotations

import numpy as np
import pytest

from reference_impl.exact.solve import solve_impact
from reference_impl.potentials import (
    FAMILIES,
    Ellipsoid,
    Expression,
    Potential,
    PowerLaw,
    SaturatingForce,
    Sphere,
    register_family,
    unregister_family,
)
from reference_impl.scenes import parse_scene, scene_from_dict
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
        assert_close(row["contact_time"], ref.contact_time, rtol=1e-12, claim="tool",
                     call=f"solve_scene(test-quartic, v0={row['v0']})")
        assert_close(row["restitution"], ref.restitution, rtol=1e-12, claim="tool",
                     call=f"solve_scene(test-quartic, v0={row['v0']})")


def test_an_unregistered_family_is_refused_naming_the_known_ones():
    from reference_impl.errors import SceneError

    with pytest.raises(SceneError, match="test-quartic.*is not one of.*'power'"):
        parse_scene(_SCENE, "<test>")


@pytest.mark.parametrize(
    "pot",
    [
        PowerLaw(2.0, 1.5),
        Ellipsoid(0.015, 0.008, 0.008, 1e8, 0.5),
        Sphere(0.01, 1e8),
        Expression("k*q**3/3 + q**2/2", k=2.0),
        SaturatingForce(2.0, 0.5),
        PowerLaw(1.0, 1.0) + Expression("q**3"),
    ],
    ids=repr,
)
def test_every_family_round_trips_through_its_scene_table(pot):
    table = potential_to_dict(pot)
    assert table["family"] in FAMILIES and FAMILIES[table["family"]].label
    scene = scene_from_dict(
        {"name": "rt", "mass": 1.0, "velocities": [0.1], "kind": "impact", "potential": table}
    )
    q = np.array([1e-4, 1e-3])
    assert_close(scene.potential.U(q), pot.U(q), rtol=0.0, claim="tool", call=f"round trip {table}")
    assert_true(potential_to_dict(scene.potential) == table, got=potential_to_dict(scene.potential),
                should=table, claim="tool", call="potential_to_dict round trip")
