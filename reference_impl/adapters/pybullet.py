"""PyBullet adapter: a sphere hitting a plane in Bullet, through the ``pybullet`` module.

Install with ``pip install -e '.[pybullet]'`` (the ``pybullet`` wheel; measured on
3.2.7). The world (``DIRECT``, no GUI) has no gravity; the sphere (the scene's effective
mass, no friction, no linear or angular damping) starts touching the plane (distance 0)
moving into it at v0. The overlap is q = R - z, dq/dt = -zdot. The force a step applied
is its impulse over dt, -m (v[n] - v[n-1]) / dt (force[0] = 0).

What Bullet integrates (checked by measurement, ``verification/test_pybullet.py``)
---------------------------------------------------------------------------------
* ``soft`` (``contactStiffness`` k, ``contactDamping`` c on both bodies): Bullet turns
  them into ERP = dt k / (dt k + c) and CFM = 1 / (dt k + c); its velocity-level solve
  is then exactly an implicit Euler step of the linear spring-dashpot k q + c dq/dt
  (the force over a step is the law at the state it ends at, to 2e-14), and the impulse
  is never negative: a contact never pulls (tension clipped). The suite's universal law
  of p = 1 with zeta = c / (2 sqrt(m k)). Bullet combines the two bodies' values:
  stiffnesses in series, k = k1 k2 / (k1 + k2), dampings added, c = c1 + c2 (a body
  without its own values counts 1e18 N/m and 0.1 N s/m, which would add 0.1 N s/m): the
  adapter writes 2 k and c / 2 on each.
* ``contactSlop`` s (PyBullet's default 1e-5 m): the solver adds s to the signed
  distance, so the spring starts only at q = s, U(q - s): declared as
  ``force_offset = -s`` (the force starts at q = -offset), which no law of the suite
  describes, so such a variant's scenes are refused by name. The adapter sets the slop
  to its option ``slop``, default 0.
* ``rigid`` (``restitution`` e on the sphere, 1 on the plane: Bullet multiplies them):
  with slop 0 the body bounces within one step without penetrating (q never > 0):
  the bench's no-penetration verdict, on e alone. Below ``restitutionVelocityThreshold``
  (PyBullet's default, option ``restitution_threshold``) Bullet applies no restitution:
  the body stops (e = 0). With a slop the rigid contact sinks to the slop and stops.
* ``soft-restitution`` (both): Bullet adds the restitution's velocity target to the
  soft constraint at every step; the result is no contact law of the suite (measured at
  zeta 0.2: e = 0.4946 for restitution 0.5, 0.4521 for 0.9, at 200 steps per contact),
  so its scenes are declined with that reason.

How PyBullet takes a restitution: ``restitution`` (rigid contact) is e itself, typed as
is; the soft contact takes a dashpot ``contactDamping`` c (N s/m), typed as the scene's
own, c = 2 zeta sqrt(m k) (tension clipped: it delivers the zero-force end, higher);
``hcv calibrate "pybullet[soft]" --param damping`` searches the c that delivers e.

Persistent mode (issue 28) does not apply: PyBullet is a Python module loaded once in
the adapter's worker process; each run connects a fresh ``DIRECT`` client.
"""

from __future__ import annotations

import ctypes
import importlib.util
import math
import os
import sys
from importlib import metadata

import numpy as np

from reference_impl.adapters._codes_common import default_radius, positive_option, split_option
from reference_impl.adapters._declaration import CodeInfo
from reference_impl.adapters.base import (
    AdapterDeclined,
    AdapterScene,
    ContactAdapter,
    ImplementedLaw,
    Trajectory,
)
from reference_impl.errors import HCVInputError
from reference_impl.potentials.power import PowerLaw

__all__ = ["MODES", "PybulletAdapter", "pybullet_available"]

MODES = ("soft", "soft-restitution", "rigid")


def pybullet_available() -> str | None:
    """None when the ``pybullet`` module is installed, else a one-line reason."""
    if importlib.util.find_spec("pybullet") is None:
        return "PyBullet is not installed; install it with pip install -e '.[pybullet]'"
    return None


def _pybullet():
    """Import ``pybullet`` with its banner ("pybullet build time: ...", printed by C on
    stdout at import) sent to stderr: stdout is the worker's channel (contract item 10)."""
    reason = pybullet_available()
    if reason:
        raise HCVInputError(reason)
    if "pybullet" in sys.modules:
        return sys.modules["pybullet"]
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        os.dup2(2, 1)
        import pybullet

        ctypes.CDLL(None).fflush(None)  # the C buffer, before fd 1 is stdout again
    finally:
        os.dup2(saved, 1)
        os.close(saved)
    return pybullet


class PybulletAdapter(ContactAdapter):
    """Normal impacts of a sphere on a plane in PyBullet (see the module docstring).

    Parameters
    ----------
    mode : str, optional
        "soft", "soft-restitution", "rigid", several joined by "+", or "all" (default).
    slop : float, optional
        ``contactSlop`` (m, >= 0; default 0). Non-zero: declared as a force offset.
    damping : float, optional
        ``contactDamping`` c of the contact (N s/m) typed instead of the scene's dashpot.
    restitution : float, optional
        ``restitution`` typed instead of the scene's asked e (rigid, soft-restitution).
    restitution_threshold : float, optional
        ``restitutionVelocityThreshold`` (m/s); default PyBullet's own.
    radius : float, optional
        Sphere radius (m); default 100 q_max at the scene's largest speed.
    """

    name = "pybullet"
    spec_values = {"mode": MODES}
    # contract item 13: what the registry, the report and CI know of PyBullet
    code_info = CodeInfo.pip(
        name,  # the extra, the marker and verification/test_<name>.py
        code="PyBullet",
        restitution_input=(
            "changeDynamics restitution = e (rigid contact, typed as is); soft contact: "
            "contactStiffness and contactDamping (a dashpot, no restitution input)"
        ),
        report_variants=(("pybullet[mode=soft]", 1.0),),
        calibrated=(("pybullet[mode=soft]", 1.0, "damping"),),
    )
    isolate = True
    # Bullet solves each contact at the velocity level with the state at the step's end:
    # on the soft contact an implicit Euler step (measured to 2e-14), order 1
    time_scheme = "implicit-euler"

    def __init__(
        self,
        mode: str | None = None,
        slop: float = 0.0,
        damping: float | None = None,
        restitution: float | None = None,
        restitution_threshold: float | None = None,
        radius: float | None = None,
    ):
        reason = pybullet_available()
        if reason:
            raise HCVInputError(f"adapter pybullet: {reason}")
        self.modes = split_option("pybullet", "mode", mode, MODES)
        self.slop = positive_option("pybullet", "slop", slop, allow_zero=True)
        self.damping = positive_option("pybullet", "damping", damping, allow_zero=True)
        self.restitution = positive_option("pybullet", "restitution", restitution, allow_zero=True)
        if self.restitution is not None and self.restitution > 1.0:
            raise HCVInputError(f"adapter pybullet: restitution must be <= 1, got {restitution!r}")
        self.restitution_threshold = positive_option(
            "pybullet", "restitution_threshold", restitution_threshold, allow_zero=True
        )
        self.radius = positive_option("pybullet", "radius", radius)

    # -- configuration ----------------------------------------------------------
    @property
    def single(self) -> bool:
        return len(self.modes) == 1

    @property
    def force_offset(self) -> float:
        """Contract: the spring starts at q = slop, i.e. at q = -offset with offset = -slop."""
        return -self.slop if self.slop else 0.0

    def _options(self) -> dict:
        return {
            "slop": self.slop,
            "damping": self.damping,
            "restitution": self.restitution,
            "restitution_threshold": self.restitution_threshold,
            "radius": self.radius,
        }

    @property
    def label(self) -> str:
        if not self.single:
            return "pybullet"
        parts = [self.modes[0]]
        for key, val in self._options().items():
            if key != "radius" and val not in (None, 0.0):
                parts.append(f"{key}={val!r}")
        return f"pybullet[{','.join(parts)}]"

    def variants(self) -> list[ContactAdapter]:
        if self.single:
            return [self]
        return [PybulletAdapter(mode=m, **self._options()) for m in self.modes]

    @classmethod
    def calibration_range(cls, param: str, scene) -> tuple[float, float] | None:
        """Default search range for ``hcv calibrate``: ``damping`` c from 1e-3 to 3 times
        the critical 2 sqrt(m k) (N s/m); ``restitution`` from 0 to 1."""
        if param == "damping":
            c1 = 2.0 * math.sqrt(scene.mass * scene.potential.k)
            return (1e-3 * c1, 3.0 * c1)
        if param == "restitution":
            return (0.0, 1.0)
        return None

    def describe(self) -> dict:
        d = {"name": self.name, "label": self.label, "mode": list(self.modes), **self._options()}
        try:
            d["version"] = metadata.version("pybullet")
        except metadata.PackageNotFoundError:  # pragma: no cover - built from source
            pass
        return d

    def supports(self, scene: AdapterScene) -> str | None:
        if not self.single:
            return "configure one mode (see variants())"
        if scene.kind != "impact":
            return f"{self.label} runs single impacts only (scene kind {scene.kind!r})"
        mode = self.modes[0]
        if mode == "soft-restitution":
            return (
                "PyBullet's soft contact with a restitution adds the restitution's velocity "
                "target to the spring-dashpot at every step: no contact law of the suite "
                "describes it (measured: e 0.4946 for restitution 0.5 at zeta 0.2)"
            )
        pot = scene.potential
        if mode == "soft" and (type(pot) is not PowerLaw or pot.p != 1.0):
            return (
                "PyBullet's soft contact is a linear spring (contactStiffness, power p = 1); "
                f"scene potential {pot!r} has no equivalent"
            )
        if mode == "soft" and self.damping is None:
            return scene.universal_only(self.label)
        return None

    def _dashpot(self, scene: AdapterScene) -> float:
        """contactDamping c of the contact (N s/m): the option, else the scene's own."""
        if self.damping is not None:
            return self.damping
        return 2.0 * float(scene.zeta or 0.0) * math.sqrt(scene.mass * scene.potential.k)

    def _restitution(self, scene: AdapterScene) -> float:
        if self.restitution is not None:
            return self.restitution
        e = scene.restitution_asked
        return 1.0 if e is None else float(e)

    def implemented_law(self, scene: AdapterScene) -> ImplementedLaw:
        reason = self.supports(scene)
        if reason:
            raise HCVInputError(f"adapter {self.label}: {reason}")
        if self.modes[0] == "rigid":  # the bench reads e alone (no penetration)
            return ImplementedLaw(
                scene.potential, scene.mass, zeta=0.0, description="rigid contact, no law"
            )
        m, k = float(scene.mass), float(scene.potential.k)
        c = self._dashpot(scene)
        zeta = c / (2.0 * math.sqrt(m * k))
        return ImplementedLaw(
            PowerLaw(k, 1.0),
            m,
            zeta=zeta,
            clips_tension=True,
            description=f"PyBullet soft contact: k q + c dq/dt clamped at 0, k = {k:.7g} N/m, "
            f"c = {c:.7g} N s/m (universal zeta = {zeta:.6g}), slop {self.slop:g} m",
            params={
                "contactStiffness": [2.0 * k, 2.0 * k],
                "contactDamping": [0.5 * c, 0.5 * c],
                "contactSlop": self.slop,
                "version": self.describe().get("version"),
            },
        )

    # -- running PyBullet -------------------------------------------------------
    def _world(self, pb, scene: AdapterScene):
        """(client, ball, radius) of one scene, the sphere touching the plane at rest."""
        cid = pb.connect(pb.DIRECT)
        kw = {"physicsClientId": cid}
        pb.setGravity(0.0, 0.0, 0.0, **kw)
        pb.setTimeStep(scene.dt, **kw)
        pb.setPhysicsEngineParameter(contactSlop=self.slop, **kw)
        if self.restitution_threshold is not None:
            pb.setPhysicsEngineParameter(
                restitutionVelocityThreshold=self.restitution_threshold, **kw
            )
        R = default_radius(scene, self.radius)
        ground = pb.createMultiBody(0.0, pb.createCollisionShape(pb.GEOM_PLANE, **kw), **kw)
        shape = pb.createCollisionShape(pb.GEOM_SPHERE, radius=R, **kw)
        ball = pb.createMultiBody(scene.mass, shape, basePosition=[0.0, 0.0, R], **kw)
        for body in (ground, ball):
            pb.changeDynamics(body, -1, lateralFriction=0.0, spinningFriction=0.0,
                              rollingFriction=0.0, linearDamping=0.0, angularDamping=0.0,
                              **kw)  # fmt: skip
        mode = self.modes[0]
        if mode in ("soft", "soft-restitution"):
            k, c = float(scene.potential.k), self._dashpot(scene)
            for body in (ground, ball):  # in series: 2k each gives k; dampings add
                pb.changeDynamics(body, -1, contactStiffness=2.0 * k, contactDamping=0.5 * c, **kw)
        if mode in ("rigid", "soft-restitution"):  # Bullet multiplies the two restitutions
            pb.changeDynamics(ball, -1, restitution=self._restitution(scene), **kw)
            pb.changeDynamics(ground, -1, restitution=1.0, **kw)
        return cid, ball, R

    def _impact_impl(self, scene: AdapterScene) -> Trajectory:
        reason = self.supports(scene)
        if reason:
            raise AdapterDeclined(reason)
        pb = _pybullet()
        cid, ball, R = self._world(pb, scene)
        kw = {"physicsClientId": cid}
        try:
            pb.resetBaseVelocity(ball, [0.0, 0.0, -scene.v0], **kw)
            n = int(scene.n_steps)
            q, v, f = np.zeros(n + 1), np.zeros(n + 1), np.zeros(n + 1)
            v[0] = scene.v0
            touched, k = False, n + 1
            for i in range(1, n + 1):
                pb.stepSimulation(**kw)
                pos = pb.getBasePositionAndOrientation(ball, **kw)[0]
                vel = pb.getBaseVelocity(ball, **kw)[0]
                q[i], v[i] = R - pos[2], -vel[2]
                f[i] = -scene.mass * (v[i] - v[i - 1]) / scene.dt
                if not (math.isfinite(q[i]) and math.isfinite(v[i])):
                    k = i + 1
                    break
                touched = touched or q[i] > 0.0
                # the end of contact, or a rigid bounce: leaving without having overlapped
                if (touched and q[i] <= 0.0) or (not touched and v[i] < 0.0):
                    k = i + 1
                    break
        finally:
            pb.disconnect(cid)
        meta = {
            "code": f"PyBullet {self.describe().get('version', '?')}",
            "mode": self.modes[0],
            "contactSlop": self.slop,
            "steps": k - 1,
        }
        return Trajectory(np.arange(k) * scene.dt, q[:k], v[:k], f[:k], meta)
