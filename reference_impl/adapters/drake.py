"""Drake adapter: a sphere on a prismatic joint hitting a half-space in a MultibodyPlant.

Install with ``pip install -e '.[drake]'`` (the ``drake`` wheel; measured on 1.51).
The plant has no gravity; the sphere (the scene's effective mass) moves along z on
a prismatic joint and starts touching the half-space (distance 0) moving into it at
v0. The overlap is q = R - z (the joint translation), dq/dt = -zdot. Friction is 0.

What Drake integrates (checked by measurement, ``verification/test_drake.py``)
-------------------------------------------------------------------------------
Point contact on a linear spring (``point_contact_stiffness`` k) with

* the continuous plant and the discrete ``lagged``, ``similar`` and ``tamsi``
  approximations: Hunt & Crossley's force k x (1 + d xdot) clamped at zero
  (``hunt_crossley_dissipation`` d, s/m): the suite's ``hunt-crossley`` law on
  U' = k q with alpha = d, tension clipped;
* the discrete ``sap`` approximation: the linear Kelvin-Voigt force k (x + tau xdot)
  clamped at zero (``relaxation_time`` tau, s): a spring k with dashpot c = k tau,
  the universal law of p = 1 with zeta = c / (2 sqrt(m k)), tension clipped.

Both geometries carry their own values and Drake combines them: k = k1 k2 / (k1 + k2),
d = (k2 d1 + k1 d2) / (k1 + k2), tau = tau1 + tau2 (`_drake_model.combine`). The
adapter writes k_ball = k (1 + r) / r and k_ground = r k_ball (option ``ground_ratio``
r, default 1), the same d on both and tau / 2 on each, so the contact gets the
scene's k, d and tau.

How Drake takes a restitution: it does not. It takes the Hunt & Crossley d
(or SAP's tau). A scene of the ``hunt-crossley`` law gives its alpha (solved for the
asked e at the asked speed): that is the d typed. A universal scene gives SAP its
dashpot over its spring, tau = 2 zeta sqrt(m / k) (the scene's own zeta, at the
overlap end: SAP clips tension, so it delivers the zero-force e, higher). The Hunt &
Crossley modes decline a universal scene (no d delivers one e at every speed) unless
``dissipation`` is given; ``hcv calibrate drake[lagged] --param dissipation``
searches the d that delivers e at one speed, ``--param relaxation_time`` SAP's tau.

Time stepping (contract item 12): the discrete plant takes first-order implicit
steps (the force over a step is the law at the step's end state: implicit Euler,
order 1; measured to 1e-11 of the peak force); the continuous plant runs Drake's
error-controlled integrator (RK3 by default) at the target ``accuracy``
(variable-step, ``scheme_rtol``), stopped at every t = n dt, its sample times.
The force of a discrete step is the impulse the step applied over dt,
-m (v[n] - v[n-1]) / dt (force[0] = 0 at q = 0); the continuous plant's is its
generalized contact force at the sampled state.

Persistent mode (issue 28) does not apply: Drake is a Python module loaded once in
the adapter's worker process, and building a plant takes milliseconds.
"""

from __future__ import annotations

import importlib.util
import math
import warnings
from importlib import metadata

import numpy as np

from reference_impl.adapters._codes_common import default_radius, positive_option, split_option
from reference_impl.adapters._declaration import CodeInfo
from reference_impl.adapters._drake_model import HC_MODES, MODES, drake_mapping
from reference_impl.adapters.base import (
    AdapterDeclined,
    AdapterScene,
    ContactAdapter,
    ImplementedLaw,
    Trajectory,
)
from reference_impl.errors import HCVInputError

__all__ = ["DrakeAdapter", "MODES", "drake_available"]

# Target accuracy of the continuous plant's error-controlled integrator (Drake's
# set_target_accuracy, a relative error): 1e-6 keeps its error below the discrete
# modes' at every step the bench runs.
_ACCURACY = 1e-6


def drake_available() -> str | None:
    """None when ``pydrake`` is installed, else a one-line reason."""
    if importlib.util.find_spec("pydrake") is None:
        return "Drake is not installed; install it with pip install -e '.[drake]'"
    return None


def _pydrake():
    """The pydrake names the adapter uses (imported on first use)."""
    reason = drake_available()
    if reason:
        raise HCVInputError(reason)
    import pydrake.all as pd

    return pd


class DrakeAdapter(ContactAdapter):
    """Normal impacts of a sphere on a half-space in Drake (see the module docstring).

    Parameters
    ----------
    mode : str, optional
        "continuous", "lagged", "similar", "tamsi", "sap", several joined by "+", or
        "all" (default: every mode, one variant each).
    dissipation : float, optional
        Hunt & Crossley d (s/m) typed instead of the scene's alpha.
    relaxation_time : float, optional
        SAP's tau (s) typed instead of the scene's dashpot over its spring.
    accuracy : float, optional
        Target accuracy of the continuous plant's integrator (relative, in (0, 1)).
    ground_ratio : float, optional
        k_ground / k_ball (> 0, default 1): how the contact's k is split between the
        two geometries (Drake's combination rule puts them in series).
    radius : float, optional
        Sphere radius (m); default 100 q_max at the scene's largest speed.
    """

    name = "drake"
    spec_values = {"mode": MODES}
    # contract item 13: what the registry, the report and CI know of Drake
    code_info = CodeInfo.pip(
        name,  # the extra, the marker and verification/test_<name>.py
        code="Drake",
        restitution_input=(
            "proximity property hunt_crossley_dissipation d (s/m; SAP: relaxation_time, s): "
            "no restitution input"
        ),
        # the side-by-side table asks a universal e on a linear spring: SAP's dashpot takes
        # it (tau = 2 zeta sqrt(m / k)); the Hunt-Crossley modes have no input for it
        report_variants=(("drake[mode=sap]", 1.0),),
        calibrated=(("drake[mode=lagged]", 1.0, "dissipation"),),
    )
    isolate = True

    def __init__(
        self,
        mode: str | None = None,
        dissipation: float | None = None,
        relaxation_time: float | None = None,
        accuracy: float = _ACCURACY,
        ground_ratio: float = 1.0,
        radius: float | None = None,
    ):
        reason = drake_available()
        if reason:
            raise HCVInputError(f"adapter drake: {reason}")
        self.modes = split_option("drake", "mode", mode, MODES)
        self.dissipation = positive_option("drake", "dissipation", dissipation, allow_zero=True)
        self.relaxation_time = positive_option(
            "drake", "relaxation_time", relaxation_time, allow_zero=True
        )
        self.accuracy = positive_option("drake", "accuracy", accuracy)
        if self.accuracy >= 1.0:
            raise HCVInputError(f"adapter drake: accuracy must be in (0, 1), got {accuracy!r}")
        self.ground_ratio = positive_option("drake", "ground_ratio", ground_ratio)
        self.radius = positive_option("drake", "radius", radius)

    # -- configuration ----------------------------------------------------------
    @property
    def single(self) -> bool:
        return len(self.modes) == 1

    @property
    def time_scheme(self) -> str:
        """Contract item 12: the continuous plant is error-controlled (variable-step), the
        discrete plant's steps are first-order implicit (implicit Euler)."""
        return "variable-step" if self.modes[0] == "continuous" else "implicit-euler"

    @property
    def scheme_rtol(self) -> float | None:
        return self.accuracy if self.modes[0] == "continuous" else None

    def _options(self) -> dict:
        return {
            "dissipation": self.dissipation,
            "relaxation_time": self.relaxation_time,
            "accuracy": self.accuracy,
            "ground_ratio": self.ground_ratio,
            "radius": self.radius,
        }

    @property
    def label(self) -> str:
        if not self.single:
            return "drake"
        parts = [self.modes[0]]
        for key in ("dissipation", "relaxation_time"):
            val = getattr(self, key)
            if val is not None:
                parts.append(f"{key}={val!r}")
        if self.accuracy != _ACCURACY and self.modes[0] == "continuous":
            parts.append(f"accuracy={self.accuracy!r}")
        if self.ground_ratio != 1.0:
            parts.append(f"ground_ratio={self.ground_ratio!r}")
        return f"drake[{','.join(parts)}]"

    def variants(self) -> list[ContactAdapter]:
        if self.single:
            return [self]
        return [DrakeAdapter(mode=m, **self._options()) for m in self.modes]

    @classmethod
    def calibration_range(cls, param: str, scene) -> tuple[float, float] | None:
        """Default search range of an option for ``hcv calibrate`` (None: none known).

        ``dissipation``: d v from 1e-3 at the scene's largest speed to 3 at its smallest
        (Hunt-Crossley restitution from ~0.999 down to ~0.2 at any of its speeds);
        ``relaxation_time``: the damping ratio k tau / (2 sqrt(m k)) from 1e-3 to 3.
        """
        speeds = [float(x) for x in (getattr(scene, "velocities", None) or (1.0,))]
        if param == "dissipation":
            return (1e-3 / max(speeds), 3.0 / min(speeds))
        if param == "relaxation_time":
            w = math.sqrt(scene.mass / scene.potential.k)
            return (2e-3 * w, 6.0 * w)
        return None

    def describe(self) -> dict:
        d = {"name": self.name, "label": self.label, "mode": list(self.modes), **self._options()}
        try:
            d["version"] = metadata.version("drake")
        except metadata.PackageNotFoundError:  # pragma: no cover - built from source
            pass
        return d

    def supports(self, scene: AdapterScene) -> str | None:
        if not self.single:
            return "configure one mode (see variants())"
        if scene.kind != "impact":
            return f"{self.label} runs single impacts only (scene kind {scene.kind!r})"
        return self._mapping(scene).get("declined")

    def _mapping(self, scene: AdapterScene) -> dict:
        return drake_mapping(
            scene,
            self.modes[0],
            dissipation=self.dissipation,
            relaxation_time=self.relaxation_time,
            ground_ratio=self.ground_ratio,
        )

    def implemented_law(self, scene: AdapterScene) -> ImplementedLaw:
        mp = self._mapping(scene)
        if "law" not in mp:
            raise HCVInputError(f"adapter {self.label}: {mp['declined']}")
        law = mp["law"]
        law.params["version"] = self.describe().get("version")
        return law

    # -- running Drake ----------------------------------------------------------
    def build(self, scene: AdapterScene, mp: dict | None = None):
        """(diagram, plant, joint, radius) of one scene; the plant is discrete with
        time step ``scene.dt`` unless the mode is continuous."""
        pd = _pydrake()
        mp = mp or self._mapping(scene)
        if "declined" in mp:
            raise AdapterDeclined(mp["declined"])
        mode = self.modes[0]
        R = default_radius(scene, self.radius)
        builder = pd.DiagramBuilder()
        plant, _sg = pd.AddMultibodyPlantSceneGraph(
            builder, 0.0 if mode == "continuous" else scene.dt
        )
        if mode != "continuous":
            approx = getattr(pd.DiscreteContactApproximation, f"k{mode.capitalize()}", None)
            if approx is None:  # pragma: no cover - TAMSI is deprecated for removal
                raise AdapterDeclined(f"this Drake has no {mode} contact approximation")
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", DeprecationWarning)
                plant.set_discrete_contact_approximation(approx)
        plant.mutable_gravity_field().set_gravity_vector([0.0, 0.0, 0.0])
        inertia = pd.SpatialInertia(scene.mass, np.zeros(3), pd.UnitInertia.SolidSphere(R))
        body = plant.AddRigidBody("ball", inertia)
        joint = plant.AddJoint(
            pd.PrismaticJoint("z", plant.world_frame(), body.body_frame(), [0.0, 0.0, 1.0])
        )

        def props(k: float, d: float, tau: float):
            p = pd.ProximityProperties()
            pd.AddContactMaterial(
                dissipation=d, point_stiffness=k, friction=pd.CoulombFriction(0.0, 0.0),
                properties=p,
            )  # fmt: skip
            p.AddProperty("material", "relaxation_time", tau)
            return p

        plant.RegisterCollisionGeometry(
            plant.world_body(), pd.RigidTransform(), pd.HalfSpace(), "ground", props(*mp["ground"])
        )
        plant.RegisterCollisionGeometry(
            body, pd.RigidTransform(), pd.Sphere(R), "ball", props(*mp["ball"])
        )
        plant.Finalize()
        return builder.Build(), plant, joint, R

    def _contact_force(self, plant, pc) -> float:
        """The generalized contact force on the joint (N, + repulsive) at the context's state."""
        inst = plant.GetModelInstanceByName("DefaultModelInstance")
        return float(plant.get_generalized_contact_forces_output_port(inst).Eval(pc)[0])

    def probe(self, scene: AdapterScene, q: float, rate: float) -> dict:
        """The continuous plant's contact force at overlap q (m), dq/dt = rate (m/s), N.

        Discrete modes: one step of ``scene.dt`` from that state, returning the state it
        ends at and the force it applied, -m (v1 - rate) / dt.
        """
        pd = _pydrake()
        diagram, plant, joint, R = self.build(scene)
        ctx = diagram.CreateDefaultContext()
        pc = plant.GetMyMutableContextFromRoot(ctx)
        joint.set_translation(pc, R - q)
        joint.set_translation_rate(pc, -rate)
        if self.modes[0] == "continuous":
            return {"force": self._contact_force(plant, pc)}
        sim = pd.Simulator(diagram, ctx)
        sim.Initialize()
        sim.AdvanceTo(scene.dt)
        q1, v1 = R - joint.get_translation(pc), -joint.get_translation_rate(pc)
        return {"q": q1, "v": v1, "force": -scene.mass * (v1 - rate) / scene.dt}

    def _impact_impl(self, scene: AdapterScene) -> Trajectory:
        pd = _pydrake()
        mp = self._mapping(scene)
        diagram, plant, joint, R = self.build(scene, mp)
        continuous = self.modes[0] == "continuous"
        sim = pd.Simulator(diagram)
        ctx = sim.get_mutable_context()
        pc = plant.GetMyMutableContextFromRoot(ctx)
        joint.set_translation(pc, R)
        joint.set_translation_rate(pc, -scene.v0)
        if continuous:
            sim.get_mutable_integrator().set_target_accuracy(self.accuracy)
        sim.Initialize()
        n = int(scene.n_steps)
        t, q, v, f = (np.zeros(n + 1) for _ in range(4))
        v[0] = scene.v0
        touched, k, failed = False, n + 1, None
        for i in range(1, n + 1):
            try:
                sim.AdvanceTo(i * scene.dt)
            except RuntimeError as exc:  # a failed solve or step-size underflow: a blow-up
                q[i] = v[i] = f[i] = math.nan
                k = i + 1
                failed = (str(exc).splitlines() or [type(exc).__name__])[0]
                break
            t[i] = i * scene.dt
            q[i], v[i] = R - joint.get_translation(pc), -joint.get_translation_rate(pc)
            if continuous:
                f[i] = self._contact_force(plant, pc)
            else:  # the impulse the implicit step applied, over dt
                f[i] = -scene.mass * (v[i] - v[i - 1]) / scene.dt
            if not (math.isfinite(q[i]) and math.isfinite(v[i])):
                k = i + 1
                break
            touched = touched or q[i] > 0.0
            if touched and q[i] <= 0.0:
                k = i + 1
                break
        t[:k] = np.arange(k) * scene.dt
        meta = {
            "code": f"Drake {self.describe().get('version', '?')}",
            "mode": self.modes[0],
            "k": mp["k"],
            "hunt_crossley_dissipation": mp["d"] if self.modes[0] in HC_MODES else None,
            "relaxation_time": mp["tau"] if self.modes[0] == "sap" else None,
            "steps": k - 1,
        }
        if failed:
            meta["failed_step"] = failed
        if continuous:
            meta["integrator"] = type(sim.get_integrator()).__name__
            meta["integrator_steps"] = int(sim.get_integrator().get_num_steps_taken())
        return Trajectory(t[:k], q[:k], v[:k], f[:k], meta)
