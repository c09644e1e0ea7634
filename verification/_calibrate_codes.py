"""A contact code with one knob, for the ``hcv calibrate`` tests (issue 29).

`LinearDashpot` is the reference velocity Verlet (dashpot at the half-step velocity)
on the scene's potential with a constant linear dashpot C = gain sqrt(m k) (kg/s),
declared as such (a power dashpot of exponent 0). On a Hooke spring its damping ratio
is zeta = gain / 2, so the exact restitution at q = 0 is exp(-pi zeta / sqrt(1 -
zeta^2)) below gain = 2, and above it the body never comes back out (overdamped). At
coarse steps the explicit dashpot goes unstable for large gains (C dt / m > 2), and
the restitution rises again above 1: a response that is not monotone.
"""

from __future__ import annotations

import math

from reference_impl.adapters import AdapterScene, ContactAdapter, Trajectory
from reference_impl.adapters.base import ImplementedLaw, PowerDamping
from reference_impl.adapters.reference import verlet_trajectory

__all__ = ["DeclinesEvery", "FailsNearTheRoot", "LinearDashpot", "gain_for"]


def gain_for(e: float) -> float:
    """The gain whose exact q = 0 restitution on a Hooke spring is ``e`` (2 zeta(e))."""
    ln = math.log(e)
    return 2.0 * -ln / math.sqrt(math.pi**2 + ln**2)


class LinearDashpot(ContactAdapter):
    """Verlet with C = gain sqrt(m k) on a power-law spring (Hooke for the tests)."""

    name = "linear-dashpot"
    isolate = False

    def __init__(self, gain: float = 0.0):
        self.gain = float(gain)

    def _damping(self, scene: AdapterScene) -> PowerDamping:
        return PowerDamping(self.gain * math.sqrt(scene.mass * float(scene.potential.k)), 0.0)

    def _impact_impl(self, scene: AdapterScene) -> Trajectory:
        t, q, v, f = verlet_trajectory(
            scene.potential, scene.mass, scene.v0, scene.dt, scene.n_steps,
            damping=self._damping(scene),
        )  # fmt: skip
        return Trajectory(t, q, v, f)

    def implemented_law(self, scene: AdapterScene) -> ImplementedLaw:
        return ImplementedLaw(scene.potential, scene.mass, zeta=None, C=self._damping(scene))


class DeclinesEvery(LinearDashpot):
    """`LinearDashpot` that declines every scene, whatever its gain."""

    name = "declines-every"

    def supports(self, scene: AdapterScene) -> str | None:
        return "no model for this scene"


class FailsNearTheRoot(LinearDashpot):
    """`LinearDashpot` whose runs raise for 0.3 < gain < 0.6 (around gain_for(0.5))."""

    name = "fails-near-the-root"

    def _impact_impl(self, scene: AdapterScene) -> Trajectory:
        if 0.3 < self.gain < 0.6:
            raise RuntimeError(f"no run at gain {self.gain}")
        return super()._impact_impl(scene)
