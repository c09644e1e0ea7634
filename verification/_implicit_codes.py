"""A first-order implicit-Euler contact code and its broken copies (issue 40, §1), for
verification/test_bench_schemes.py.

`ImplicitEuler` integrates the scene's own law with backward Euler (the scheme Drake's
discrete modes take: q and v at the new step, the force at the new state), declares
``time_scheme = "implicit-euler"`` and claims order 1: a correct implementation of its
law whose error at 200 steps per contact (~1e-2 in e) is ten times velocity Verlet's.
`DampingOff` integrates a dashpot 10 % too strong while declaring the scene's law;
`ForceTimesTwo` reports twice the force it integrates (a units bug), and
`ForceTimes1e300` 1e300 times it. Python adapters run in-process.
"""

from __future__ import annotations

import numpy as np

from reference_impl.adapters import AdapterScene, ContactAdapter, Trajectory
from reference_impl.adapters.base import ImplementedLaw, Scheme
from reference_impl.adapters.law_damping import scene_law
from reference_impl.bench.scorecard._schemes import scheme_trajectory

_IMPLICIT = Scheme("implicit-euler", 1.0)


class ImplicitEuler(ContactAdapter):
    name = "implicit-euler"
    isolate = False
    time_scheme = "implicit-euler"
    claimed_order = 1.0
    damping_factor = 1.0  # the dashpot integrated, x the declared one
    force_factor = 1.0  # the force reported, x the one integrated

    def supports(self, scene: AdapterScene) -> str | None:
        if scene.kind != "impact":
            return "single impacts only"
        return None

    def _impact_impl(self, scene: AdapterScene) -> Trajectory:
        law = scene_law(scene)
        if self.damping_factor != 1.0:
            c = law.damping_coefficient
            law = ImplementedLaw(law.potential, law.mass, C=lambda q: self.damping_factor * c(q))
        t, q, v, f = scheme_trajectory(law, _IMPLICIT, scene.v0, scene.dt, scene.n_steps)
        return Trajectory(t, q, v, np.asarray(f) * self.force_factor)


class DampingOff(ImplicitEuler):
    name = "implicit-euler-damping-10pc"
    damping_factor = 1.1


class ForceTimesTwo(ImplicitEuler):
    name = "implicit-euler-force-x2"
    force_factor = 2.0


class ForceTimes1e300(ImplicitEuler):
    name = "implicit-euler-force-x1e300"
    force_factor = 1e300


class VariableStep(ContactAdapter):
    """scipy's RK45 at rtol 1e-8, sampled at t = n dt (a variable-step, error-controlled
    code: its ``dt`` is its sampling)."""

    name = "variable-step"
    isolate = False
    time_scheme = "variable-step"
    scheme_rtol = 1e-8

    def supports(self, scene: AdapterScene) -> str | None:
        return "single impacts only" if scene.kind != "impact" else None

    def _impact_impl(self, scene: AdapterScene) -> Trajectory:
        scheme = Scheme("variable-step", None, self.scheme_rtol)
        t, q, v, f = scheme_trajectory(scene_law(scene), scheme, scene.v0, scene.dt, scene.n_steps)
        return Trajectory(t, q, v, f)


class Declared(ImplicitEuler):
    """A correct code of any fixed-step scheme: the bench's own scheme on the scene's law,
    declared as such (``Declared.of("explicit-euler")``)."""

    @classmethod
    def of(cls, scheme: str, order: float = 1.0) -> Declared:
        return type(f"Declared_{scheme}", (cls,), {"name": scheme, "time_scheme": scheme,
                                                     "claimed_order": order})()  # fmt: skip

    def _impact_impl(self, scene: AdapterScene) -> Trajectory:
        scheme = Scheme(self.time_scheme, float(self.claimed_order))
        t, q, v, f = scheme_trajectory(scene_law(scene), scheme, scene.v0, scene.dt, scene.n_steps)
        return Trajectory(t, q, v, f)
