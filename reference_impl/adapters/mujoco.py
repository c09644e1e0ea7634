"""MuJoCo adapter: a body on a slide joint hitting a plane, through the ``mujoco`` Python module.

Install with ``pip install -e '.[mujoco]'`` (MuJoCo 3.x or 4.x wheels). The
model is written as MJCF in memory: no gravity, a sphere of mass m (the scene's
effective mass) on a slide joint along z over a plane, ``condim = 1``
(frictionless normal contact), the same ``solref`` / ``solimp`` on both geoms
(so MuJoCo's mixing leaves them unchanged), margin 0. The sphere starts touching
the plane (distance 0) moving into it at v0. The overlap is q = -qpos (the joint
displacement, so R never enters q's rounding), dq/dt = -qvel, and the force the
contact puts on the body is ``qfrc_constraint`` (equal to ``efc_force`` of the
contact row and to ``mj_contactForce``; checked in the tests).

What MuJoCo integrates (engine_core_constraint.c, checked by measurement)
-------------------------------------------------------------------------
A frictionless contact row gets the reference acceleration
aref = -B v_n - K I(r) r (r = -q the signed distance, v_n = -dq/dt) and, with no
other force, the solver gives the acceleration a = g(I) aref with
g(I) = I / (I + rho (1 - I)), rho = m A_diag (A_diag = ``efc_diagA``, MuJoCo 4;
``efc_diagApprox`` before; 1/m for this model, so rho = 1 and a = I aref). The
force is m a when a >= 0 and 0 otherwise: a contact never pulls (tension
clipped). With d_w = solimp[1]:

* ``solref = "direct"``: solref = (-S, -D), K = S / d_w^2, B = D / d_w. These are
  per unit mass (1/s^2, 1/s): the adapter writes S = k / m and D = c / m. Never
  clamped.
* ``solref = "timeconst"``: solref = (tc, dr), K = 1 / (d_w^2 tc^2 dr^2),
  B = 2 / (d_w tc). MuJoCo replaces tc by max(tc, 2 timestep) (``refsafe``, the
  positive form only): the adapter applies the same clamp and declares the law of
  the clamped value. dr = 0 would be a *mixed-sign* solref, which MuJoCo silently
  replaces by its default (0.02, 1): undamped scenes are declined in this form.

Impedance I(r) (``solimp`` = dmin, dmax, width, midpoint, power; every value
clamped by MuJoCo to [1e-4, 0.9999], as the adapter does before declaring):

* ``impedance = "constant"``: dmin = dmax = d (option ``imp``, default 0.9).
  Then the force is m g(d) (K d q + B dq/dt), clipped at 0: a linear spring
  k q with a constant dashpot c, i.e. the universal law of p = 1 with
  zeta = c / (2 sqrt(m k)), tension clipped. With rho = 1 the direct form
  gives exactly k = m S, c = m D and the timeconst form k = m / (tc dr)^2,
  c = 2 m / tc (so dr is the damping ratio and 1/(tc dr) the natural frequency).
* ``impedance = "default"``: MuJoCo's default solimp (0.9, 0.95, 0.001, 0.5, 2)
  (``width`` overridable). For q <= midpoint x width, I = dmin + 2 (dmax - dmin)
  (q / width)^2, so the law is a sum of powers U'(q) = m K I(q)^2 q (terms q,
  q^3, q^5) with the polynomial damping C(q) = m B I(q) (terms 1, q^2),
  declared as ``{"law": "polynomial", "c": [...]}``. Beyond the midpoint I is
  another polynomial piece: scenes whose overlap would reach it are declined with
  the width that would hold them. Declared for rho = 1 only (else g(I) is not a
  polynomial).

The stiffness asked is the scene's k (at full impedance dmax); the damping is
calibrated to the restitution the scene asks (``restitution_asked``, at the scene's
``restitution_end``), read at the end option ``end``: ``overlap`` (zeta whose q = 0
restitution exp(-pi zeta / sqrt(1 - zeta^2)) is the asked e: the scene's zeta when
it asks at the overlap end) or ``zero-force`` (what a code that clips tension
delivers: zeta from exp(-2 zeta arccos zeta / sqrt(1 - zeta^2)) = e, see
`zeta_zero_force`; the scene's zeta when it asks at the zero-force end). A damping
law other than the universal one (or none) is declined: MuJoCo's constant dashpot
is the universal law of p = 1 only. Options ``dampratio`` (the damping ratio used, replaces the
calibration) or ``damping`` (c in N s/m) set it directly: they are what
``hcv calibrate mujoco --param dampratio`` searches.

Facts the adapter handles
-------------------------
* A contact at distance 0 gets no constraint row (``dist < margin`` creates it),
  so the first step from q = 0 carries no force although the dashpot law has
  c v0 there: part of MuJoCo's first-order error, not hidden.
* After ``mj_step`` the ``efc_*`` arrays and ``qfrc_constraint`` hold the state
  the step started from (for RK4 its last stage): the adapter calls
  ``mj_forward`` after every step so that the force is the one at the sampled
  state (no staggering left to declare).
* MuJoCo resets the state silently when an acceleration is non-finite or above
  1e10 m/s^2 (``mjMAXVAL``; a stiff contact reaches it with a valid state)
  unless ``autoreset`` is disabled: the adapter disables it, so the run goes on
  and a blow-up shows as one (non-finite samples); the warnings are counted in
  ``meta["badqacc_warnings"]``. On a MuJoCo without that flag a reset ends the
  run with non-finite samples instead of a clean-looking restart.
* MuJoCo 4 renamed ``efc_diagApprox`` to ``efc_diagA``: both are read.
* Numbers are written into the XML as ``repr(float(x))``.
* MuJoCo's warnings (printed on stdout and appended to ``MUJOCO_LOG.TXT`` in the
  current directory by default) go to stderr: no stray output, no file left.

Integrators: ``Euler`` (semi-implicit: v then q with the new v), ``RK4``,
``implicit`` (implicit only in passive damping and actuators, so the same
contact as ``Euler``; run as its own variant to show it).
"""

from __future__ import annotations

import importlib.util
import math
import sys
from importlib import metadata

import numpy as np

from reference_impl.adapters._codes_common import positive_option, refuse_scene, split_option
from reference_impl.adapters._declaration import CodeInfo
from reference_impl.adapters._mujoco_model import asked_zeta, mjcf, scene_mapping
from reference_impl.adapters._mujoco_support import (
    _badqacc_index,
    _diag,
    restitution_zero_force_linear,
    zeta_zero_force,
)
from reference_impl.adapters.base import (
    AdapterDeclined,
    AdapterScene,
    ContactAdapter,
    ImplementedLaw,
    Trajectory,
)
from reference_impl.errors import HCVInputError

__all__ = [
    "END",
    "IMPEDANCES",
    "INTEGRATORS",
    "MujocoAdapter",
    "SOLREF_FORMS",
    "mujoco_available",
    "restitution_zero_force_linear",
    "zeta_zero_force",
]

SOLREF_FORMS = ("direct", "timeconst")
IMPEDANCES = ("constant", "default")
INTEGRATORS = ("Euler", "RK4", "implicit")
END = ("overlap", "zero-force")
_CONSTANT_IMP = 0.9  # MuJoCo's default dmin, used as the constant impedance

_MUJOCO = None


def mujoco_available() -> str | None:
    """None when the ``mujoco`` module is installed, else a one-line reason."""
    if importlib.util.find_spec("mujoco") is None:
        return "MuJoCo is not installed; install it with pip install -e '.[mujoco]'"
    return None


def load_mujoco():
    """Import ``mujoco`` (once)."""
    global _MUJOCO
    if _MUJOCO is None:
        reason = mujoco_available()
        if reason:
            raise HCVInputError(reason)
        import mujoco

        # MuJoCo's default warning handler prints to stdout and appends to
        # MUJOCO_LOG.TXT in the current directory: route warnings to stderr instead
        # (stdout is the worker's channel, and an adapter leaves no files behind).
        setter = getattr(mujoco, "set_mju_user_warning", None)
        if setter is not None:
            setter(_warning_to_stderr)
        _MUJOCO = mujoco
    return _MUJOCO


def _warning_to_stderr(message) -> None:
    print(f"MuJoCo warning: {message}", file=sys.stderr)


class MujocoAdapter(ContactAdapter):
    """Normal impacts of a body on a plane in MuJoCo (see the module docstring for the law).

    Parameters
    ----------
    solref : str, optional
        "direct" (-S -D), "timeconst" (timeconst dampratio), joined by "+", or "all".
    impedance : str, optional
        "constant" (solimp dmin = dmax) or "default" (MuJoCo's solimp), "+" or "all".
    integrator : str, optional
        "Euler", "RK4", "implicit", "+" or "all".
    end : str, optional
        Calibration of the damping: "overlap" (asked restitution at q = 0) or
        "zero-force" (at the zero-force end), "+" or "all"; default "overlap".
    dampratio : float, optional
        Damping ratio used instead of the calibration (dimensionless, >= 0).
    damping : float, optional
        Dashpot c (N s/m, at full impedance) used instead of the calibration.
    imp : float, optional
        Constant impedance d of ``impedance=constant`` (default 0.9; clamped to
        [1e-4, 0.9999] like MuJoCo).
    width : float, optional
        solimp width (m) of ``impedance=default`` (default MuJoCo's 0.001 m).
    radius : float, optional
        Sphere radius (m); default 100 q_max at the scene's largest speed.

    Without options the variants are: direct/constant with each integrator,
    timeconst/constant/Euler, direct/constant/Euler calibrated at the zero-force
    end, and direct/default/Euler.
    """

    name = "mujoco"
    # Values that name their key in a variant label (mujoco[direct,constant,Euler] is what
    # the scorecard prints and what hcv bench accepts back).
    spec_values = {
        "solref": SOLREF_FORMS,
        "impedance": IMPEDANCES,
        "integrator": INTEGRATORS,
        "end": END,
    }
    # contract item 13: what the registry, the report and CI know of MuJoCo
    code_info = CodeInfo.pip(
        name,  # the extra, the marker and verification/test_<name>.py
        code="MuJoCo",
        restitution_input=(
            "geom solref = (timeconst, dampratio): the damping ratio of the linear "
            "spring-dashpot (no restitution input)"
        ),
        report_variants=(("mujoco[solref=timeconst,impedance=constant,integrator=Euler]", 1.0),),
        calibrated=(
            ("mujoco[solref=timeconst,impedance=constant,integrator=Euler]", 1.0, "dampratio"),
        ),
    )
    isolate = True

    def __init__(
        self,
        solref: str | None = None,
        impedance: str | None = None,
        integrator: str | None = None,
        end: str | None = None,
        dampratio: float | None = None,
        damping: float | None = None,
        imp: float = _CONSTANT_IMP,
        width: float | None = None,
        radius: float | None = None,
    ):
        reason = mujoco_available()
        if reason:
            raise HCVInputError(f"adapter mujoco: {reason}")
        self._default_set = solref is None and impedance is None and integrator is None
        self._default_set = self._default_set and end is None
        self.forms = split_option("mujoco", "solref", solref, SOLREF_FORMS)
        self.imps = split_option("mujoco", "impedance", impedance, IMPEDANCES)
        self.integrators = split_option("mujoco", "integrator", integrator, INTEGRATORS)
        # the calibration end is a setting (default overlap), a variant axis only when asked
        self.ends = split_option("mujoco", "end", "overlap" if end is None else end, END)
        if dampratio is not None and damping is not None:
            raise HCVInputError("adapter mujoco: give dampratio or damping, not both")
        self.dampratio = positive_option("mujoco", "dampratio", dampratio, allow_zero=True)
        self.damping = positive_option("mujoco", "damping", damping, allow_zero=True)
        self.imp = positive_option("mujoco", "imp", imp)
        self.width = positive_option("mujoco", "width", width)
        self.radius = positive_option("mujoco", "radius", radius)

    # -- configuration ----------------------------------------------------------
    @property
    def time_scheme(self) -> str:
        """Contract item 12: ``Euler`` is semi-implicit (v then q with the new v), i.e.
        symplectic Euler, and ``implicit`` is the same on a contact (implicit in passive
        damping only); ``RK4`` is the classical fourth-order Runge-Kutta."""
        return "rk4" if self.integrators[0] == "RK4" else "symplectic-euler"

    @classmethod
    def calibration_range(cls, param: str, scene) -> tuple[float, float] | None:
        """Default search range of an option for ``hcv calibrate`` (None: none known).

        Damping ratios 1e-3 to 3 (asked at full impedance): restitution from 0.997
        down to 0.02 at the zero-force end of a clipped linear contact.
        """
        if param == "dampratio":
            return (1e-3, 3.0)
        if param == "damping":
            c1 = 2.0 * math.sqrt(scene.mass * scene.potential.k)  # zeta = 1
            return (1e-3 * c1, 3.0 * c1)
        return None

    def _options(self) -> dict:
        return {
            "dampratio": self.dampratio,
            "damping": self.damping,
            "imp": self.imp,
            "width": self.width,
            "radius": self.radius,
        }

    @property
    def single(self) -> bool:
        return all(len(x) == 1 for x in (self.forms, self.imps, self.integrators, self.ends))

    @property
    def label(self) -> str:
        if not self.single:
            return "mujoco"
        parts = [self.forms[0], self.imps[0], self.integrators[0]]
        if self.ends[0] != "overlap":
            parts.append(self.ends[0])
        for key in ("dampratio", "damping"):
            val = getattr(self, key)
            if val is not None:
                parts.append(f"{key}={val!r}")
        return f"mujoco[{','.join(parts)}]"

    def variants(self) -> list[ContactAdapter]:
        if self.single:
            return [self]
        kw = self._options()
        if self._default_set:
            combos = [("direct", "constant", i, "overlap") for i in INTEGRATORS] + [
                ("timeconst", "constant", "Euler", "overlap"),
                ("direct", "constant", "Euler", "zero-force"),
                ("direct", "default", "Euler", "overlap"),
            ]
        else:
            combos = [
                (f, i, g, e)
                for f in self.forms
                for i in self.imps
                for g in self.integrators
                for e in self.ends
            ]
        return [
            MujocoAdapter(solref=f, impedance=i, integrator=g, end=e, **kw) for f, i, g, e in combos
        ]

    def describe(self) -> dict:
        d = {
            "name": self.name,
            "label": self.label,
            "solref": list(self.forms),
            "impedance": list(self.imps),
            "integrator": list(self.integrators),
            "end": list(self.ends),
        }
        try:
            d["version"] = metadata.version("mujoco")
        except metadata.PackageNotFoundError:  # pragma: no cover - installed from source
            pass
        return d

    def supports(self, scene: AdapterScene) -> str | None:
        reason = refuse_scene(
            self,
            scene,
            configure="solref form, impedance, integrator and end",
            powers=(1.0,),
            no_power="MuJoCo's soft contact is a linear spring (U' = k q, power p = 1); scene "
            f"potential {scene.potential!r} has no equivalent",
        )
        if reason:
            return reason
        if self.forms[0] == "timeconst" and self._zeta(scene) == 0.0:
            return (
                "solref timeconst form cannot express zero damping: dampratio 0 makes a "
                "mixed-sign solref, which MuJoCo silently replaces by its default (0.02, 1); "
                "use solref=direct"
            )
        if self.imps[0] == "default":
            mp = self._mapping(scene)
            if "declined" in mp:
                return mp["declined"]
        return None

    # -- the mapping (reference_impl.adapters._mujoco_model) -----------------------
    def _zeta(self, scene: AdapterScene) -> float:
        """Damping ratio asked of MuJoCo at full impedance."""
        return asked_zeta(scene, self.ends[0], self.dampratio, self.damping)

    def _mapping(self, scene: AdapterScene, rho: float = 1.0) -> dict:
        """MuJoCo parameters and the law it integrates for one scene (`scene_mapping`).

        ``rho`` = m efc_diagA (1 for this model in every version measured; the
        run reads the real value and re-declares with it).
        """
        return scene_mapping(
            scene,
            rho,
            form=self.forms[0],
            impedance=self.imps[0],
            integrator=self.integrators[0],
            end=self.ends[0],
            **self._options(),
        )

    def _rho(self, scene: AdapterScene) -> float:
        """m efc_diagA measured on the compiled model (constant for a slide joint)."""
        key = (scene.mass, scene.dt, tuple(sorted(scene.potential_spec.items())))
        cache = self.__dict__.setdefault("_rho_cache", {})
        if key not in cache:
            q_top = float(scene.potential.turning_point(0.5 * scene.mass * scene.v0**2))
            probe = self.probe(scene, 0.5 * q_top, 0.0)
            if "rho" not in probe:
                raise HCVInputError(
                    f"adapter {self.label}: MuJoCo made no contact at q = {0.5 * q_top:g} m"
                )
            rho = probe["rho"]
            # m * (1/m) is 1 to a few ulps; 1e-12 keeps g(I) - 1 below 1e-13
            cache[key] = 1.0 if math.isclose(rho, 1.0, rel_tol=1e-12) else rho
        return cache[key]

    def implemented_law(self, scene: AdapterScene) -> ImplementedLaw:
        mp = self._mapping(scene, self._rho(scene))
        if "law" not in mp:
            raise HCVInputError(f"adapter {self.label}: {mp.get('declined')}")
        law = mp["law"]
        return ImplementedLaw(
            law.potential,
            law.mass,
            zeta=law.zeta,
            C=law.C,
            clips_tension=True,
            description=law.description,
            params={
                "solref": list(mp["solref"]),
                "solimp": list(mp["solimp"]),
                "timeconst_clamped": mp["clamped"],
                "integrator": self.integrators[0],
                "zeta_asked": mp["zeta_asked"],
                "version": self.describe().get("version"),
            },
        )

    # -- running MuJoCo -----------------------------------------------------------
    def build(self, scene: AdapterScene, autoreset: bool = False):
        """The compiled (MjModel, MjData, mapping) of one scene, autoreset disabled.

        ``autoreset=True`` keeps MuJoCo's default (for the test that shows the hazard).
        """
        mj = load_mujoco()
        mp = self._mapping(scene)
        if "declined" in mp:
            raise AdapterDeclined(mp["declined"])
        model = mj.MjModel.from_xml_string(mjcf(mp, scene, self.integrators[0]))
        bit = getattr(mj.mjtDisableBit, "mjDSBL_AUTORESET", None)
        if bit is not None and not autoreset:
            model.opt.disableflags |= int(bit)
        data = mj.MjData(model)
        return model, data, mp

    def probe(self, scene: AdapterScene, q: float, rate: float) -> dict:
        """MuJoCo's contact force at overlap q (m) and dq/dt = rate (m/s), read three ways.

        One ``mj_forward`` at that state: ``qfrc_constraint``, ``efc_force`` of the
        contact row and ``mj_contactForce`` (N, + repulsive), and m efc_diagA.
        """
        mj = load_mujoco()
        model, data, _mp = self.build(scene)
        data.qpos[0], data.qvel[0] = -q, -rate
        mj.mj_forward(model, data)
        out = {"qfrc_constraint": float(data.qfrc_constraint[0]), "ncon": int(data.ncon)}
        if data.ncon:
            adr = int(data.contact.efc_address[0])
            out["efc_force"] = float(data.efc_force[adr])
            f6 = np.zeros(6)
            mj.mj_contactForce(model, data, 0, f6)
            out["contact_force"] = float(f6[0])
            out["rho"] = scene.mass * float(_diag(data)[adr])
        return out

    def _impact_impl(self, scene: AdapterScene) -> Trajectory:
        mj = load_mujoco()
        model, data, mp = self.build(scene)
        mp = self._mapping(scene, self._rho(scene))
        if "declined" in mp:
            raise AdapterDeclined(mp["declined"])
        n = int(scene.n_steps)
        t = np.empty(n + 1)
        q = np.empty(n + 1)
        v = np.empty(n + 1)
        f = np.empty(n + 1)
        data.qvel[0] = -scene.v0
        mj.mj_forward(model, data)
        t[0], q[0], v[0], f[0] = 0.0, 0.0, scene.v0, float(data.qfrc_constraint[0])
        warn = _badqacc_index(mj)
        autoreset_off = getattr(mj.mjtDisableBit, "mjDSBL_AUTORESET", None) is not None
        reset_seen = data.warning[warn].number
        touched, k = False, n + 1
        for i in range(1, n + 1):
            mj.mj_step(model, data)
            # the efc_* arrays after mj_step are those of the state the step started from:
            # recompute them at the new state so the force sample is the force at t[i]
            mj.mj_forward(model, data)
            t[i] = i * scene.dt
            q[i], v[i], f[i] = -data.qpos[0], -data.qvel[0], data.qfrc_constraint[0]
            if not autoreset_off and data.warning[warn].number > reset_seen:
                # this MuJoCo has no autoreset flag and has just reset the state
                q[i] = v[i] = f[i] = math.nan  # a blow-up, never a silent reset
                k = i + 1
                break
            if not (math.isfinite(q[i]) and math.isfinite(v[i])):
                k = i + 1
                break
            touched = touched or q[i] > 0.0
            if touched and q[i] <= 0.0:
                k = i + 1
                break
        meta = {
            "code": f"MuJoCo {self.describe().get('version', '?')}",
            "solref": list(mp["solref"]),
            "solimp": list(mp["solimp"]),
            "integrator": self.integrators[0],
            "timeconst_clamped": mp["clamped"],
            "steps": k - 1,
            "m_diagA": self._rho(scene),
            # |qacc| > 1e10 (mjMAXVAL) or non-finite: MuJoCo warns; with autoreset
            # disabled it goes on, so the count says how often, not that the run is void
            "badqacc_warnings": int(data.warning[warn].number),
        }
        return Trajectory(t[:k], q[:k], v[:k], f[:k], meta)
