"""Deliberately wrong contact codes for the gate tests (verification/test_bench_gate.py).

Each is a `ContactAdapter` run in-process (like the reference adapter) that declares
the scene's own law (the default `implemented_law`) but breaks it in one known way:

* `ConstantDashpot`: a constant dashpot C = C_universal(q_max(v_mid) / 2), frozen at
  half the peak overlap of the scene's middle speed (what a code calibrating one
  constant per scene does); on a Hertz contact its restitution depends on v0.
* `FlippedSign`: reports the overlap with the wrong sign (the gap, not the overlap).
* `LaggedForce`: reports, at t[n], the force of step n - 1 without declaring it.
* `FirstOrder`: explicit (forward) Euler, a first-order scheme. (Symplectic Euler
  would not do: its positions are exactly Verlet's, its velocities Verlet's half-step
  ones, so in free flight it reports the same restitution.)

They integrate U'(q) = k q^p (power family) only and decline other scenes.

`MisCalibrated` is correct but mis-calibrated (issue 26): the reference Verlet with a
damping ratio whose restitution is ~8 % off the asked one, declared honestly, so that
it implements its law as well as a correct code (implementation passes) and never
delivers what the scene asks (delivery fails), at any step.
"""

from __future__ import annotations

import math

import numpy as np

from reference_impl.adapters import AdapterScene, ContactAdapter, Trajectory
from reference_impl.adapters.reference import verlet_trajectory


def _power(scene: AdapterScene) -> tuple[float, float]:
    spec = scene.potential_spec
    return float(spec["k"]), float(spec["p"])


class _PowerOnly(ContactAdapter):
    isolate = False

    def supports(self, scene: AdapterScene) -> str | None:
        if scene.potential_spec.get("family") != "power":
            return "power laws only"
        if scene.kind != "impact":
            return "single impacts only"
        return None


class FlippedSign(_PowerOnly):
    name = "wrong-flipped-sign"

    def _impact_impl(self, scene):
        t, q, v, f = verlet_trajectory(
            scene.potential, scene.mass, scene.v0, scene.dt, scene.n_steps, zeta=scene.zeta
        )
        return Trajectory(t, -q, v, f)


class LaggedForce(_PowerOnly):
    name = "wrong-lagged-force"

    def _impact_impl(self, scene):
        t, q, v, f = verlet_trajectory(
            scene.potential, scene.mass, scene.v0, scene.dt, scene.n_steps, zeta=scene.zeta
        )
        lagged = np.concatenate([[0.0], f[:-1]])
        return Trajectory(t, q, v, lagged)


class ConstantDashpot(_PowerOnly):
    name = "wrong-constant-dashpot"

    def _impact_impl(self, scene):
        k, p = _power(scene)
        m = scene.mass
        vs = sorted(scene.velocities)
        v_mid = vs[len(vs) // 2]
        q_ref = 0.5 * scene.potential.turning_point(0.5 * m * v_mid * v_mid)
        # the universal law's C(q) = 2 zeta sqrt(m) U'/sqrt(2U), frozen at q_ref
        c = (
            2.0
            * scene.zeta
            * math.sqrt(m)
            * k
            * q_ref**p
            / math.sqrt(2.0 * k * q_ref ** (p + 1) / (p + 1))
        )
        return _loop(scene, k, p, lambda q, vel: k * q**p + c * vel, verlet=True)


class FirstOrder(_PowerOnly):
    name = "wrong-first-order"

    def _impact_impl(self, scene):
        k, p = _power(scene)
        c = 2.0 * scene.zeta * math.sqrt(scene.mass)
        kp = math.sqrt(2.0 * k / (p + 1))  # U'/sqrt(2U) = sqrt(2k/(p+1)) q^((p-1)/2)

        def force(q, vel):
            return k * q**p + c * kp * q ** (0.5 * (p - 1.0)) * vel

        return _loop(scene, k, p, force, verlet=False)


def _loop(scene, k, p, force, verlet: bool) -> Trajectory:
    """Velocity Verlet (dashpot at the half-step velocity) or explicit Euler."""
    m, dt, n_max = scene.mass, scene.dt, scene.n_steps
    t, q, v, f = [0.0], [0.0], [scene.v0], [0.0]
    y, vel, F, touched = 0.0, scene.v0, 0.0, False
    for n in range(1, n_max + 1):
        if verlet:
            vh = vel - 0.5 * dt * F / m
            y += dt * vh
            F = force(y, vh) if y > 0 else 0.0
            vel = vh - 0.5 * dt * F / m
        else:  # explicit Euler: drift and kick with the state (q_n, v_n)
            y, vel = y + dt * vel, vel - dt * F / m
            F = force(y, vel) if y > 0 else 0.0
        touched = touched or y > 0
        if not (math.isfinite(y) and math.isfinite(vel)):
            y = vel = F = math.nan
        t.append(n * dt)
        q.append(y)
        v.append(vel)
        f.append(F)
        if (touched and y <= 0) or not math.isfinite(y):
            break
    return Trajectory(np.array(t), np.array(q), np.array(v), np.array(f))


def constant_damping(q):
    """A damping coefficient given as a plain callable, C(q) = 1 kg/s."""
    return 0.0 * np.asarray(q, dtype=float) + 1.0


class DeclaresLaw(ContactAdapter):
    """Runs the reference Verlet but declares another law (``which``), for the gate tests.

    ``which``: "p25" (power law p = 25), "zeta" (zeta = 1e308), "sphere" (R = 1e-12 m),
    "c" (power damping c = 1e300) or "callable" (a plain callable C(q)).
    """

    name = "declares-law"
    isolate = False

    def __init__(self, which: str = "p25", **kw):
        super().__init__(**kw)
        self.which = which

    def _impact_impl(self, scene):
        t, q, v, f = verlet_trajectory(
            scene.potential, scene.mass, scene.v0, scene.dt, scene.n_steps, zeta=scene.zeta
        )
        return Trajectory(t, q, v, f)

    def implemented_law(self, scene):
        from reference_impl.adapters import ImplementedLaw, PowerDamping
        from reference_impl.potentials import PowerLaw, Sphere

        pot, m, z = scene.potential, scene.mass, scene.zeta
        return {
            "p25": lambda: ImplementedLaw(PowerLaw(1e10, 25.0), m, zeta=z),
            "zeta": lambda: ImplementedLaw(pot, m, zeta=1e308),
            "sphere": lambda: ImplementedLaw(Sphere(R=1e-12, Kn=1e10), m, zeta=z),
            "c": lambda: ImplementedLaw(pot, m, zeta=None, C=PowerDamping(1e300, 0.25)),
            "callable": lambda: ImplementedLaw(pot, m, zeta=None, C=constant_damping),
        }[self.which]()


class DeclinesAll(ContactAdapter):
    """Declines every scene while running (contract item 7)."""

    name = "declines-all"
    isolate = False

    def _impact_impl(self, scene):
        from reference_impl.adapters import AdapterDeclined

        raise AdapterDeclined("no model for this scene")


class MisCalibrated(ContactAdapter):
    """The reference Verlet run, and declared, with a mis-calibrated damping ratio.

    The restitution it runs is 8 % above the asked one (8 % below where that would
    exceed 0.9): zeta' = zeta_from_restitution(e'), declared in `implemented_law`.
    """

    name = "mis-calibrated"
    isolate = False
    OFF = 0.08  # relative restitution error of the calibration (4 x the delivery rtol)

    def _zeta(self, scene) -> float:
        from reference_impl.theory.damping import zeta_from_restitution

        e = scene.restitution
        e_run = e * (1 + self.OFF) if e * (1 + self.OFF) <= 0.9 else e * (1 - self.OFF)
        return float(zeta_from_restitution(e_run))

    def _impact_impl(self, scene):
        t, q, v, f = verlet_trajectory(
            scene.potential, scene.mass, scene.v0, scene.dt, scene.n_steps,
            zeta=self._zeta(scene),
        )  # fmt: skip
        return Trajectory(t, q, v, f)

    def implemented_law(self, scene):
        from reference_impl.adapters import ImplementedLaw

        return ImplementedLaw(scene.potential, scene.mass, zeta=self._zeta(scene))
