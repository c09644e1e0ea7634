"""The suite's own velocity Verlet, run through the adapter contract (the baseline).

The trajectories come from the one Verlet recorder,
`reference_impl.integrators.verlet_path` (the lane engine's scheme, conventions and
force kernel; any other `Potential` in a plain Python loop); here they are run with
the law an adapter scene or an `ImplementedLaw` asks for.
"""

from __future__ import annotations

from reference_impl.adapters.base import (
    AdapterScene,
    ContactAdapter,
    ImplementedLaw,
    PowerDamping,
    Trajectory,
)
from reference_impl.adapters.law_damping import LawDamping, scene_law
from reference_impl.integrators.verlet_path import verlet_trajectory
from reference_impl.theory.laws import is_harmonic

__all__ = ["ReferenceAdapter", "law_trajectory", "verlet_trajectory"]


def law_trajectory(law: ImplementedLaw, v0: float, dt: float, n_steps: int):
    """Velocity-Verlet impact trajectory of an `ImplementedLaw` (the textbook scheme with
    exactly the law a code declares): the baseline of the critical-step comparison.

    Raises
    ------
    TypeError
        When the law's damping is an opaque callable (not `LawDamping` / `PowerDamping`).
    """

    if isinstance(law.C, LawDamping):
        # any law of the table: C(q) evaluated per step (the recorder's Python loop)
        return verlet_trajectory(
            law.potential, law.mass, v0, dt, n_steps, clip=law.clips_tension, c_fun=law.C
        )
    if law.C is not None and not isinstance(law.C, PowerDamping):
        raise TypeError(
            f"the reference Verlet runs the laws of reference_impl.theory.laws (LawDamping, "
            f"PowerDamping, universal), not {law.C!r}"
        )
    return verlet_trajectory(
        law.potential,
        law.mass,
        v0,
        dt,
        n_steps,
        zeta=law.zeta or 0.0,
        damping=law.C,
        clip=law.clips_tension,
    )


class ReferenceAdapter(ContactAdapter):
    """Our velocity Verlet with the exact force law of the scene, any damping law.

    It is the baseline every other adapter is compared with, run through the
    same contract, and it implements exactly the law it is asked for: the universal
    law by its ratio, every other law of `reference_impl.theory.laws` with the
    parameters the scene sends (a law solved from a restitution: the solved strength).
    """

    name = "reference"
    isolate = False
    supports_sustained = True

    def supports(self, scene: AdapterScene) -> str | None:
        if scene.kind not in ("impact", "two-walls"):
            return f"reference runs impact and two-walls scenes, not {scene.kind!r}"
        return None

    def describe(self) -> dict:
        return {
            "name": self.name,
            "label": self.label,
            "scheme": "velocity Verlet (kick-drift-kick), dashpot at the half-step velocity",
        }

    def _damping(self, scene: AdapterScene) -> dict:
        """verlet_trajectory's damping keywords for the scene's law."""
        if is_harmonic(scene.damping):
            return {"zeta": scene.zeta}
        C = scene_law(scene).C
        if isinstance(C, PowerDamping):
            return {"damping": C}
        return {"c_fun": C}  # a LawDamping: C(q) evaluated at each step

    def _impact_impl(self, scene: AdapterScene) -> Trajectory:
        t, q, v, f = verlet_trajectory(
            scene.potential, scene.mass, scene.v0, scene.dt, scene.n_steps, **self._damping(scene)
        )
        return Trajectory(t, q, v, f, {"steps": int(t.size - 1)})

    def _sustained_impl(self, scene: AdapterScene) -> Trajectory:
        t, q, v, f = verlet_trajectory(
            scene.potential,
            scene.mass,
            scene.v0,
            scene.dt,
            scene.n_steps,
            kind="two-walls",
            gap=float(scene.gap or 0.0),
            **self._damping(scene),
        )
        return Trajectory(t, q, v, f, {"steps": int(t.size - 1)})
