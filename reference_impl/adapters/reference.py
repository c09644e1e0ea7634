"""The suite's own velocity Verlet, run through the adapter contract (the baseline).

Same scheme and conventions as the lane engine of
`reference_impl.integrators.verlet` (kick-drift-kick, the dashpot of the
universal law evaluated with the half-step velocity), but it records the whole
trajectory, as the contract asks. Known potential families run in a numba
kernel (the lane engine's force routine); any other `Potential` runs in a plain
Python loop.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from reference_impl.adapters.base import (
    AdapterScene,
    ContactAdapter,
    ImplementedLaw,
    PowerDamping,
    Trajectory,
)
from reference_impl.integrators.verlet import SCENE_IMPACT, SCENE_WALLS, _force_energy, kernel_terms

__all__ = ["ReferenceAdapter", "law_trajectory", "verlet_trajectory"]


@numba.njit(cache=True)
def _traj_kernel(
    fam, par, q_sup, m, c_damp, c_pow, a_pow, clip, dt, v0, n_steps, scene, gap, t, q, v, f
):
    """Integrate one body; fill t, q, v, f (repulsive force) and return the sample count.

    Damping: the universal law with 2 zeta sqrt(m) = c_damp, plus c_pow q^a_pow; with
    ``clip`` a tensile total force is set to 0.
    """
    y = 0.0
    vel = v0 if scene == SCENE_IMPACT else -v0  # two-walls: at the lower wall, moving into it
    F = 0.0
    half = 0.5 * dt / m
    t[0] = 0.0
    q[0] = 0.0
    v[0] = vel
    f[0] = 0.0
    touched = False
    for n in range(1, n_steps + 1):
        vh = vel + half * F
        y = y + dt * vh
        if scene == SCENE_IMPACT:
            qq = y
            sgn = -1.0
        elif y > gap:
            qq = y - gap
            sgn = -1.0
        elif y < 0.0:
            qq = -y
            sgn = 1.0
        else:
            qq = max(y - gap, -y)
            sgn = 0.0
        rep = 0.0
        if qq > 0.0:
            if not qq <= q_sup:
                t[n] = n * dt
                q[n] = np.nan
                v[n] = np.nan
                f[n] = np.nan
                return n + 1
            fe, U = _force_energy(qq, fam, par)
            rep = fe
            if c_damp > 0.0 and U > 0.0:
                # dq/dt at the half step is -sgn * vh
                rep += c_damp * fe / math.sqrt(2.0 * U) * (-sgn * vh)
            if c_pow > 0.0:
                rep += c_pow * qq**a_pow * (-sgn * vh)
            if clip and rep < 0.0:
                rep = 0.0
            touched = True
        F = sgn * rep
        vel = vh + half * F
        t[n] = n * dt
        q[n] = qq
        f[n] = rep
        v[n] = vel
        if scene == SCENE_IMPACT and touched and qq <= 0.0:
            return n + 1
    return n_steps + 1


def _traj_python(pot, m, c_damp, c_pow, a_pow, clip, dt, v0, n_steps, scene, gap, c_fun=None):
    """The same loop for potentials without a kernel (one scalar call per step); ``c_fun``
    adds any other damping C(q) (a `LawDamping`), evaluated at each step."""
    t = np.zeros(n_steps + 1)
    q = np.zeros(n_steps + 1)
    v = np.zeros(n_steps + 1)
    f = np.zeros(n_steps + 1)
    y, vel = (0.0, v0) if scene == SCENE_IMPACT else (0.0, -v0)
    v[0] = vel
    F, half, touched = 0.0, 0.5 * dt / m, False
    for n in range(1, n_steps + 1):
        vh = vel + half * F
        y += dt * vh
        if scene == SCENE_IMPACT:
            qq, sgn = y, -1.0
        elif y > gap:
            qq, sgn = y - gap, -1.0
        elif y < 0.0:
            qq, sgn = -y, 1.0
        else:
            qq, sgn = max(y - gap, -y), 0.0
        rep = 0.0
        if qq > 0.0:
            if not qq <= pot.q_sup:
                t[n], q[n], v[n], f[n] = n * dt, np.nan, np.nan, np.nan
                return t[: n + 1], q[: n + 1], v[: n + 1], f[: n + 1]
            arr = np.array([qq])
            fe, U = float(pot._dU(arr)[0]), float(pot._U(arr)[0])
            rep = fe
            if c_damp > 0.0 and U > 0.0:
                rep += c_damp * fe / math.sqrt(2.0 * U) * (-sgn * vh)
            if c_pow > 0.0:
                rep += c_pow * qq**a_pow * (-sgn * vh)
            if c_fun is not None:
                rep += float(c_fun(arr)[0]) * (-sgn * vh)
            if clip and rep < 0.0:
                rep = 0.0
            touched = True
        F = sgn * rep
        vel = vh + half * F
        t[n], q[n], v[n], f[n] = n * dt, qq, vel, rep
        if scene == SCENE_IMPACT and touched and qq <= 0.0:
            return t[: n + 1], q[: n + 1], v[: n + 1], f[: n + 1]
    return t, q, v, f


def verlet_trajectory(
    pot,
    m: float,
    v0: float,
    dt: float,
    n_steps: int,
    *,
    zeta: float = 0.0,
    kind: str = "impact",
    gap: float = 0.0,
    damping: PowerDamping | None = None,
    clip: bool = False,
):
    """Velocity-Verlet trajectory (t, q, v, force) of one impact or a two-walls run.

    Damping: the universal law of ratio ``zeta`` and/or ``damping`` (C = c q^a);
    ``clip`` sets a tensile total force to 0 (codes that forbid attraction).

    Impact: starts at contact onset (q = 0, dq/dt = v0) and stops at the first step
    with q <= 0 after contact, or after ``n_steps``. Two-walls: starts at the onset
    of the lower wall's contact moving into it; q is the overlap with the nearer
    wall (negative in flight) and v the body's velocity along the axis.
    """
    scene = SCENE_IMPACT if kind == "impact" else SCENE_WALLS
    c_damp = 2.0 * zeta * math.sqrt(m)
    c_pow, a_pow = (0.0, 0.0) if damping is None else (float(damping.c), float(damping.exponent))
    terms = kernel_terms(pot)
    # The same scalar arguments feed the Python fallback and the compiled kernel.
    args = (
        float(m),
        c_damp,
        c_pow,
        a_pow,
        bool(clip),
        float(dt),
        float(v0),
        int(n_steps),
        scene,
        float(gap),
    )
    if terms is None:
        return _traj_python(pot, *args)
    n = int(n_steps) + 1
    t, q, v, f = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    k = _traj_kernel(
        terms[0],
        terms[1],
        float(pot.q_sup),
        *args,
        t,
        q,
        v,
        f,
    )
    return t[:k], q[:k], v[:k], f[:k]


def law_trajectory(law: ImplementedLaw, v0: float, dt: float, n_steps: int):
    """Velocity-Verlet impact trajectory of an `ImplementedLaw` (the textbook scheme with
    exactly the law a code declares): the baseline of the critical-step comparison.

    Raises
    ------
    TypeError
        When the law's damping is an opaque callable (not `LawDamping` / `PowerDamping`).
    """
    from reference_impl.adapters.law_damping import LawDamping

    if isinstance(law.C, LawDamping):
        # any law of the table: the same loop, C(q) evaluated per step (plain Python)
        return _traj_python(
            law.potential,
            float(law.mass),
            0.0,
            0.0,
            0.0,
            bool(law.clips_tension),
            float(dt),
            float(v0),
            int(n_steps),
            SCENE_IMPACT,
            0.0,
            c_fun=law.C,
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
    """Our velocity Verlet with the exact force law of the scene (universal damping).

    It is the baseline every other adapter is compared with, run through the
    same contract, and it implements exactly the law it is asked for.
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

    def _impact_impl(self, scene: AdapterScene) -> Trajectory:
        t, q, v, f = verlet_trajectory(
            scene.potential, scene.mass, scene.v0, scene.dt, scene.n_steps, zeta=scene.zeta
        )
        return Trajectory(t, q, v, f, {"steps": int(t.size - 1)})

    def _sustained_impl(self, scene: AdapterScene) -> Trajectory:
        t, q, v, f = verlet_trajectory(
            scene.potential,
            scene.mass,
            scene.v0,
            scene.dt,
            scene.n_steps,
            zeta=scene.zeta,
            kind="two-walls",
            gap=float(scene.gap or 0.0),
        )
        return Trajectory(t, q, v, f, {"steps": int(t.size - 1)})
