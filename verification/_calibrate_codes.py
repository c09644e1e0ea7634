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
import random

import numpy as np

from reference_impl.adapters import AdapterScene, ContactAdapter, Trajectory
from reference_impl.adapters.base import ImplementedLaw, PowerDamping
from reference_impl.adapters.reference import verlet_trajectory

__all__ = [
    "DeclinesEvery",
    "FailsNearTheRoot",
    "LinearDashpot",
    "NoisyDashpot",
    "NoisyJump",
    "gain_for",
]


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


class NoisyDashpot(LinearDashpot):
    """`LinearDashpot` whose delivered restitution carries Gaussian noise of standard
    deviation `NOISE` (a code with a random packing, a thermostat, threads summing in any
    order): each run adds NOISE x N(0, 1) to -v / v0 from the first sample back at q <= 0.
    The draws are seeded (`reseed`), so a test sees the same sequence every time."""

    name = "noisy-dashpot"
    NOISE = 1e-4
    _draws = random.Random(0)

    @classmethod
    def reseed(cls, seed: int) -> None:
        cls._draws = random.Random(seed)

    def _impact_impl(self, scene: AdapterScene) -> Trajectory:
        tr = super()._impact_impl(scene)
        inside = np.flatnonzero(tr.q > 0)
        out = np.flatnonzero(tr.q[inside[0] :] <= 0) + inside[0] if inside.size else []
        v = np.array(tr.v, dtype=float)
        if len(out):
            v[out[0] :] -= self._shift() * scene.v0
        return Trajectory(tr.t, tr.q, v, tr.force)

    def _shift(self) -> float:
        """What this run adds to the restitution."""
        return self.NOISE * self._draws.gauss(0.0, 1.0)


class NoisyJump(NoisyDashpot):
    """`NoisyDashpot` whose restitution also drops by `DROP` above gain `JUMP_AT`: from
    about 0.52 to 0.32 across the target 0.5 (met at gain 0.433 without the drop), a
    jump no noise explains."""

    name = "noisy-jump"
    JUMP_AT, DROP = 0.4, 0.2

    def _shift(self) -> float:
        return super()._shift() - (self.DROP if self.gain > self.JUMP_AT else 0.0)


class FlakyDashpot(LinearDashpot):
    """`LinearDashpot` whose every `EVERY`-th run ends in NaN velocities: a code that fails
    intermittently (a lost process, a race), deterministic otherwise. The count is per
    class (`reset`), so a test sees the same failures every time."""

    name = "flaky-dashpot"
    EVERY = 3
    _runs = 0

    @classmethod
    def reset(cls) -> None:
        cls._runs = 0

    def _impact_impl(self, scene: AdapterScene) -> Trajectory:
        tr = super()._impact_impl(scene)
        type(self)._runs += 1
        if type(self)._runs % self.EVERY:
            return tr
        v = np.array(tr.v, dtype=float)
        v[-1] = np.nan
        return Trajectory(tr.t, tr.q, v, tr.force)


class BrokenAbove(LinearDashpot):
    """`LinearDashpot` whose every run fails (NaN velocities) above gain `FAIL_ABOVE`,
    which the bracket of the target 0.5 (met at gain 0.433) needs: it fails twice there,
    so that bracket is lost, and the message must not call the target out of reach."""

    name = "broken-above"
    FAIL_ABOVE = 0.3

    def _impact_impl(self, scene: AdapterScene) -> Trajectory:
        tr = super()._impact_impl(scene)
        if self.gain <= self.FAIL_ABOVE:
            return tr
        v = np.array(tr.v, dtype=float)
        v[-1] = np.nan
        return Trajectory(tr.t, tr.q, v, tr.force)
