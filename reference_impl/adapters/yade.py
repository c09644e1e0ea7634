"""YADE adapter: Hertz-Mindlin and ViscElMat contacts of the Debian ``yade`` program.

Install with ``apt-get install -y yade`` (Debian 12: Yade 2023.02a). YADE starts
in about 3 s, so the adapter keeps one ``yade -n -x _yade_server.py`` process for
all its runs and variants (the persistent mode, `reference_impl.adapters._persistent`):
requests and answers are JSON lines; a hung request or a dead process fails that
run only and the next run starts a fresh YADE. The script it runs is
`reference_impl.adapters._yade_server` (which also lists the traps it avoids).

Scene -> YADE (from the sources, ``pkg/dem/HertzMindlin.cpp`` and
``pkg/dem/ViscoelasticPM.cpp`` of YADE 2023; the places are named by function and
by the source's own section comments, not by line: the 2023.02a tree itself was
not at hand, the copies read were later ones, and every formula below is checked
by measurement against the Debian 2023.02a build in ``verification/test_yade.py``)
--------------------------------------------------------------------------
Geometry "wall": a sphere of radius R and mass m on ``utils.wall`` (z = 0, fixed,
mass 0); "pair": two spheres of radius R and mass 2m head-on (reduced mass m).
R defaults to 100 q_max (a 1 % overlap). Poisson ratio 0, no friction, no gravity,
``NewtonIntegrator(damping=0)``.

Hertz-Mindlin (``Ip2_FrictMat_FrictMat_MindlinPhys`` + ``Law2_ScGeom_MindlinPhys_Mindlin``)::

    E* = Ea Eb / ((1 - Va^2) Eb + (1 - Vb^2) Ea),  R* = Da Db / (Da + Db)
    kno = 4/3 E* sqrt(R*)                        (Ip2 ... ::go, "Kno")
    Fn = kno uN^(3/2),  kn = 3/2 kno uN^(1/2)    (Law2 ... ::go, "NORMAL FORCE")
    cn = 2 sqrt(mbar kn) betan                   ("DAMPING COEFFICIENTS", Cn_crit)
    normal force - cn vn, set to 0 if negative   ("VISCOUS DAMPING", normTemp < 0)

A wall counts as a sphere of the same radius (Da = Db = R: R* = R/2, measured),
mbar is the dynamic body's mass (m on a wall). So U' = k q^(3/2) with
k = kno and C = 2 betan sqrt(3/2 k m) q^(1/4): the universal law with
**zeta = betan sqrt(6/5)**, tension clipped. Input ``en`` sets betan by
Thornton et al. 2013, eqs. (B6)-(B7) (`thornton_betan`), fitted so that the
clipped Hertz contact leaves at en (to the fit's accuracy). Input ``betan`` is
given directly.

What is typed (protocol ``hcv-adapter/2``; issue 40, §2): the scene's
``restitution_asked`` e goes into YADE's input as its documentation says and a user
types it (`_typed_e`): ``en`` gets e itself (YADE sets betan by Thornton's fit); ``tc``
gets en = e and tc = sqrt((pi^2 + ln^2 e) m / k) (Pournin 2001: the linear contact of
restitution e at q = 0), which YADE's wall quirk below turns into another law on a
wall; ``kn`` gets cn = 2 (2 zeta sqrt(m k)) per material, zeta = -ln e / sqrt(pi^2 +
ln^2 e) of that same linear contact. YADE clips tension, so every input delivers the
zero-force restitution of its law: a scene asking e at the overlap end gets more than e
from the ViscElMat inputs, and the delivery verdict says by how much; the input that
would deliver the asked e is ``hcv calibrate yade[...] --param en|cn``, a separate,
labelled answer (the ``en``, ``tc``, ``cn`` options type given values). ``betan`` is a
damping ratio, not an e: it gets zeta_a / sqrt(6/5), zeta_a the zeta whose zero-force
restitution is the asked e (`reference_impl.adapters._asked`), and delivers it.

ViscElMat (``Ip2_ViscElMat_ViscElMat_ViscElPhys`` + ``Law2_ScGeom_ViscElPhys_Basic``)::

    massR = m1 m2 / (m1 + m2), a zero mass replaced by the other one's
    tc/en: kn_i = 2 massR (pi^2 + ln^2 en) / tc^2,  cn_i = -4 massR ln(en) / tc   [Pournin 2001]
    kn = kn1 kn2 / (kn1 + kn2), cn likewise            (contactParameterCalculation)
    Fn = kn uN + cn vn, set to 0 if negative           (computeForceTorqueViscEl)

* input ``tc`` (tc, en as a user sets them for stiffness k and mass m:
  tc = sqrt((pi^2 + ln^2 e) m / k)): two spheres give massR = m and exactly the
  asked k and zeta. **On a wall the wall's zero mass is replaced by the sphere's,
  massR = m/2**: k comes out k/2, c out c/2 (zeta / sqrt(2)), the contact 42 %
  long and e too high (0.929 for 0.9). Declared as such.
* input ``kn`` (kn, cn per material): the contact gets half of each (springs in
  series), so the adapter writes kn = 2k, cn = 2c and the law is the asked one.

Both clip tension. Linear laws (p = 1) only for ViscElMat, p = 3/2 for Mindlin.

ViscElMat computes its force at a penetration depth of exactly 0 too (only a
negative depth ends the contact, ``computeForceTorqueViscEl``): the first step
from the onset already carries the dashpot force c v0, where textbook Verlet's
contact starts at q > 0. YADE's positions are the leapfrog of the declared law with
that rule to round-off (`verification/test_yade.py`,
``test_viscelmat_counts_depth_zero_as_contact``), and it is a first-order difference
from the textbook rule (3.4 % of q_max at 50 steps per contact, 1.7 % at 100): on the
gate, ``max_penetration`` of ``hooke-damped`` at 200 steps per contact is 0.56 % low
against the declared scheme's allowance of 0.49 % for ``kn`` on a wall and ``tc``
between spheres (e = 0.5 typed), whose laws are otherwise the asked one, so they fail implementation
there. It is YADE's behaviour, not a wrong law: the declared law's description says
it. Hertz-Mindlin has no force at depth 0 (U' and C vanish).

Staggering: YADE is leapfrog. After ``O.step()`` the position is x[n+1], the
velocity v[n+1/2] and ``O.forces`` the force of the step, computed at x[n] with
the velocity v[n-1/2] (``getIncidentVel``): declared ``{"force": 1, "v": 0.5}``
and re-aligned by `ContactAdapter.impact` (contract item 11). The dashpot's
half-step velocity is the one textbook velocity Verlet uses too, so the
positions are those of the reference Verlet.
"""

from __future__ import annotations

import math
import os
import shutil

import numpy as np

from reference_impl.adapters._asked import asked_universal_zeta, delivery_end
from reference_impl.adapters._codes_common import (
    bool_option,
    default_radius,
    positive_option,
    refuse_scene,
    split_option,
)
from reference_impl.adapters._declaration import CodeInfo
from reference_impl.adapters._lattice_request import LatticeRequest
from reference_impl.adapters._persistent import PersistentProcess
from reference_impl.adapters._yade_chain import chain_scene, parse_advice, parse_chain
from reference_impl.adapters._yade_lattice import lattice_scene, parse_lattice
from reference_impl.adapters.base import (
    AdapterDeclined,
    AdapterRunError,
    AdapterScene,
    ContactAdapter,
    ImplementedLaw,
    Trajectory,
)
from reference_impl.errors import HCVInputError
from reference_impl.potentials.power import PowerLaw
from reference_impl.theory.damping import zeta_from_restitution

__all__ = [
    "GEOMETRIES",
    "INPUTS",
    "INSTALL",
    "YadeAdapter",
    "thornton_betan",
    "yade_available",
]

# Damping input -> contact law: en / betan are Hertz-Mindlin, tc / kn are ViscElMat.
INPUTS = ("en", "betan", "tc", "kn")
GEOMETRIES = ("wall", "pair")
INSTALL = "apt-get install -y yade"
_LAW = {"en": "mindlin", "betan": "mindlin", "tc": "viscel", "kn": "viscel"}
# Seconds allowed to YADE's own start-up on top of a run's timeout (~3 s measured).
_STARTUP = 120.0
# Answer size bound (bytes per sample: 3 numbers of ~25 characters and separators).
_BYTES_PER_SAMPLE = 96
_SERVER = os.path.join(os.path.dirname(os.path.abspath(__file__)), "_yade_server.py")
# Thornton et al. 2013, Table 2: h1..h10 of eq. (B7) (as in HertzMindlin.cpp).
_THORNTON_H = (
    -6.918798,
    -16.41105,
    146.8049,
    -796.4559,
    2928.711,
    -7206.864,
    11494.29,
    -11342.18,
    6276.757,
    -1489.915,
)


def yade_available() -> str | None:
    """None when the ``yade`` program is on PATH, else a one-line reason."""
    if shutil.which("yade") is None:
        return f"YADE is not installed; install it with {INSTALL} (Debian/Ubuntu)"
    return None


def thornton_betan(e: float) -> float:
    """betan YADE sets for ``en = e`` (Thornton et al. 2013, eqs. B6-B7)."""
    if e >= 1.0:
        return 0.0
    poly = 0.0
    for h in reversed(_THORNTON_H):  # Horner: e (h1 + e (h2 + ... + e h10))
        poly = h + e * poly
    alphan = e * poly
    return math.sqrt(1.0 / (1.0 - (1.0 + e) ** 2 * math.exp(alphan)) - 1.0)


def _typed_e(scene: AdapterScene) -> float:
    """The e a user types into YADE (``en``, and with ``tc`` the e of its formula): the
    asked e itself, 1 without damping (issue 40, §2)."""
    return float(scene.restitution_asked) if scene.damping != "none" else 1.0


class YadeAdapter(ContactAdapter):
    """Head-on normal impacts in YADE (see the module docstring for the law).

    Parameters
    ----------
    input : str, optional
        Damping input: "en" or "betan" (Hertz-Mindlin), "tc" (ViscElMat tc/en) or
        "kn" (ViscElMat kn/cn); joined by "+", or "all".
    geometry : str, optional
        "wall", "pair" or "wall+pair" (default "wall").
    radius : float, optional
        Sphere radius R (m); default 100 q_max at the scene's largest speed.
    timeout : float, optional
        Seconds per run (default: the benchmark's per-run timeout, else 60).
    persistent : bool
        Keep one YADE process for every run (default). False starts a YADE per
        run (~3 s each), as a one-shot ``cmd:`` adapter does: for comparison.
    en, betan, cn : float, optional
        The damping input written instead of the one mapped from the scene: ``en``
        for inputs en and tc (tc the one of the asked e unless given), ``betan`` for input
        betan, ``cn`` (per material, N s/m) for input kn. What ``hcv calibrate
        yade[...] --param en|betan|cn`` searches.
    tc : float, optional
        Contact time (s) written for input tc instead of the one of the asked e (with
        ``en``: the pair a user types for an e of their own).

    Without options the variants are every input on the wall, and en and tc
    between two spheres.
    """

    name = "yade"
    isolate = False  # YADE runs in its own process, bounded by `PersistentProcess`
    # contract item 14: Hertz chains and periodic lattices (`_yade_chain`, `_yade_lattice`)
    supports_assembly = True
    supports_lattice = True
    spec_values = {"input": INPUTS, "geometry": GEOMETRIES}
    # contract item 13: what the registry, the report and CI know of YADE
    code_info = CodeInfo(
        code="YADE",
        restitution_input=(
            "FrictMat + Ip2_FrictMat_FrictMat_MindlinPhys(en=e); ViscElMat(tc, en) or "
            "(kn, cn) per material"
        ),
        report_variants=(("yade[en,wall]", 1.5), ("yade[tc,wall]", 1.0), ("yade[kn,wall]", 1.0)),
        calibrated=(
            ("yade[input=en,geometry=wall]", 1.5, "en"),
            ("yade[input=tc,geometry=wall]", 1.0, "en"),
        ),
        apt="yade",
        marker="yade",
        test_module="verification/test_yade.py",
    )
    # leapfrog: the force of a step belongs to the sample before, v to half a step before
    staggering = {"force": 1, "v": 0.5}

    def __init__(
        self,
        input: str | None = None,
        geometry: str | None = None,
        radius: float | None = None,
        timeout: float | None = None,
        persistent: bool = True,
        en: float | None = None,
        betan: float | None = None,
        cn: float | None = None,
        tc: float | None = None,
    ):
        reason = yade_available()
        if reason:
            raise HCVInputError(f"adapter yade: {reason}")
        self._default_set = input is None and geometry is None
        self.inputs = split_option("yade", "input", input, INPUTS)
        geometry = "wall" if geometry is None else geometry
        self.geoms = split_option("yade", "geometry", geometry, GEOMETRIES)
        self.radius = positive_option("yade", "radius", radius)
        timeout = positive_option("yade", "timeout", timeout)
        self.timeout_given = timeout is not None
        self.timeout = 60.0 if timeout is None else timeout
        self.persistent = bool_option("yade", "persistent", persistent)
        self.given = {}
        for key, val, ok in (
            ("en", en, lambda x: 0.0 < x <= 1.0),
            ("betan", betan, lambda x: x >= 0.0),
            ("cn", cn, lambda x: x >= 0.0),
            ("tc", tc, lambda x: math.isfinite(x) and x > 0.0),
        ):
            if val is None:
                continue
            if isinstance(val, bool) or not isinstance(val, (int, float)) or not ok(val):
                raise HCVInputError(f"adapter yade: {key} out of range, got {val!r}")
            self.given[key] = float(val)
        if self.given and len(self.inputs) > 1:
            raise HCVInputError(
                "adapter yade: en, betan, cn and tc need one input (e.g. yade[en,wall,en=0.5])"
            )
        if self.given:
            used = {"en": {"en"}, "tc": {"en", "tc"}, "betan": {"betan"}, "kn": {"cn"}}
            used = used[self.inputs[0]]
            unused = sorted(set(self.given) - used)
            if unused:
                raise HCVInputError(
                    f"adapter yade: option {unused[0]!r} is not used by input {self.inputs[0]!r} "
                    f"(it takes {', '.join(sorted(used))})"
                )
        self._server: PersistentProcess | None = None

    # -- configuration ----------------------------------------------------------
    @property
    def single(self) -> bool:
        return len(self.inputs) == 1 and len(self.geoms) == 1

    @property
    def label(self) -> str:
        if not self.single:
            return "yade"
        extra = "".join(f",{k}={v!r}" for k, v in self.given.items())
        return f"yade[{self.inputs[0]},{self.geoms[0]}{extra}]"

    @classmethod
    def calibration_range(cls, param: str, scene) -> tuple[float, float] | None:
        """Search range of ``hcv calibrate`` for the options en, betan and cn."""
        if param == "en":
            return (1e-3, 1.0)
        if param == "betan":
            return (0.0, 2.0)
        if param == "cn":
            return (0.0, 2.0 * 2.0 * 2.0 * math.sqrt(scene.mass * scene.potential.k))
        return None

    def variants(self) -> list[ContactAdapter]:
        if self.single:
            return [self]
        combos = [(i, g) for g in self.geoms for i in self.inputs]
        if self._default_set:
            combos += [("en", "pair"), ("tc", "pair")]
        out = []
        for i, g in combos:
            v = YadeAdapter(
                input=i,
                geometry=g,
                radius=self.radius,
                timeout=self.timeout,
                persistent=self.persistent,
                **self.given,
            )
            v.timeout_given = self.timeout_given
            v._server = self.server  # one YADE process serves every variant
            out.append(v)
        return out

    @property
    def server(self) -> PersistentProcess:
        if self._server is None:
            self._server = PersistentProcess(
                ["yade", "-n", "-x", _SERVER], label="yade", startup_timeout=_STARTUP
            )
        return self._server

    def describe(self) -> dict:
        return {
            "name": self.name,
            "label": self.label,
            "input": list(self.inputs),
            "geometry": list(self.geoms),
            "law": sorted({_LAW[i] for i in self.inputs}),
            "process": "persistent (one yade for all runs)" if self.persistent else "one per run",
        }

    def supports(self, scene: AdapterScene) -> str | None:
        mindlin = _LAW[self.inputs[0]] == "mindlin"
        want = 1.5 if mindlin else 1.0
        reason = refuse_scene(
            self,
            scene,
            configure="input and geometry",
            powers=(want,),
            no_power=f"YADE {'Hertz-Mindlin' if mindlin else 'ViscElMat'} is U' = k "
            f"q^{want:g}; scene potential {scene.potential!r} has no equivalent",
        )
        if reason:
            return reason
        if self.inputs[0] in ("en", "tc", "kn") and _typed_e(scene) <= 0.0:
            return (
                f"YADE's {self.inputs[0]} input needs e > 0, got asked e = "
                f"{scene.restitution_asked:g} (typed as is)"
            )
        return None

    # -- the mapping ------------------------------------------------------------
    def mapping(self, scene: AdapterScene) -> dict:
        """YADE inputs for one scene and the law they give (see the module docstring)."""
        pot, m = scene.potential, scene.mass
        inp, geom = self.inputs[0], self.geoms[0]
        # YADE clips tension: the zeta whose zero-force e is the asked one, at either end
        zeta_asked = asked_universal_zeta(scene, delivery_end(scene, clips_tension=True))
        R = default_radius(scene, self.radius)
        body_mass = m if geom == "wall" else 2.0 * m
        sc: dict = {"geometry": geom, "R": float(R), "mass": float(body_mass)}
        k_law, zeta = pot.k, 0.0
        if _LAW[inp] == "mindlin":
            e = self.given.get("en", _typed_e(scene) if inp == "en" else 1.0)
            # E* = Y/2 (same material, nu = 0), R* = R/2 on a wall and for two spheres
            sc.update(law="mindlin", young=float(2.0 * 0.75 * pot.k / math.sqrt(0.5 * R)))
            betan = (
                thornton_betan(e)
                if inp == "en"
                else self.given.get("betan", zeta_asked / math.sqrt(1.2))
            )
            sc["ip2"] = ["en", float(e)] if inp == "en" else ["betan", float(betan)]
            zeta = betan * math.sqrt(1.2)
            src = f"Thornton 2013 B6-B7 of en = {e:.6g} (typed)" if inp == "en" else "given"
            how = f"betan = {betan:.6g} ({src})"
        elif inp == "tc":
            e_user = _typed_e(scene)
            e = self.given.get("en", e_user)
            la = math.log(e_user) if e_user > 0 else 0.0
            tc = self.given.get("tc", math.sqrt((math.pi**2 + la * la) * m / pot.k))  # user's
            le = math.log(e)
            sc.update(law="viscel", material={"tc": tc, "en": float(e), "et": float(e)})
            mass_r = m / 2.0 if geom == "wall" else m  # the wall's 0 mass -> the sphere's
            k_law = (math.pi**2 + le * le) * mass_r / tc**2
            c = -2.0 * le * mass_r / tc
            zeta = c / (2.0 * math.sqrt(m * k_law))
            how = f"tc = {tc:.6g} s, en = {e:.6g}: massR = {mass_r / m:g} m, kn = {k_law:.6g}"
        else:
            # typed: the linear contact of restitution e at q = 0 (Pournin), per material
            e_typed = _typed_e(scene)
            zeta_typed = float(zeta_from_restitution(e_typed)) if e_typed < 1.0 else 0.0
            c = (
                self.given["cn"] / 2.0
                if "cn" in self.given
                else 2.0 * zeta_typed * math.sqrt(m * pot.k)
            )
            zeta_asked = c / (2.0 * math.sqrt(m * pot.k))
            sc.update(
                law="viscel",
                material={"kn": 2.0 * pot.k, "cn": 2.0 * c, "ks": 0.0, "cs": 0.0},
            )
            zeta = zeta_asked
            how = f"material kn = 2k = {2.0 * pot.k:.6g}, cn = 2c = {2.0 * c:.6g} (in series: k, c)"
        return {"scene": sc, "k": float(k_law), "zeta": float(zeta), "how": how}

    def implemented_law(self, scene: AdapterScene) -> ImplementedLaw:
        mp = self.mapping(scene)
        pot = scene.potential if mp["k"] == scene.potential.k else PowerLaw(mp["k"], 1.0)
        law = "Hertz-Mindlin" if mp["scene"]["law"] == "mindlin" else "ViscElMat"
        # ViscElMat's contact starts at depth 0: the onset step carries c v0 (docstring)
        onset = (
            "; contact from depth 0 (the onset step carries c v0: first order in dt)"
            if law == "ViscElMat" and mp["zeta"] > 0
            else ""
        )
        return ImplementedLaw(
            pot,
            scene.mass,
            zeta=mp["zeta"],
            clips_tension=True,
            description=f"{law} {self.inputs[0]}: {mp['how']}; universal law zeta = "
            f"{mp['zeta']:.6g}, tension clipped{onset}",
            params={**mp["scene"], "input": self.inputs[0]},
        )

    # -- running YADE -------------------------------------------------------------

    def _ask(self, req: dict, n_samples: int) -> dict:
        limit = (1 << 20) + _BYTES_PER_SAMPLE * (n_samples + 2)
        try:
            ans = self.server.request(req, timeout=self.timeout, limit=limit)
        finally:
            if not self.persistent:
                self.server.close()
        if "error" in ans:
            raise AdapterRunError(f"{self.label}: YADE: {str(ans['error'])[:300]}")
        return ans

    def _impact_impl(self, scene: AdapterScene) -> Trajectory:
        reason = self.supports(scene)
        if reason:
            raise AdapterDeclined(reason)
        mp = self.mapping(scene)
        req = {
            "op": "impact",
            "scene": mp["scene"],
            "dt": scene.dt,
            "n_steps": int(scene.n_steps),
            "v0": scene.v0,
        }
        ans = self._ask(req, int(scene.n_steps) + 1)
        arr = {
            k: np.array([np.nan if x is None else x for x in ans[k]], dtype=float)
            for k in ("q", "v", "f")
        }
        t = scene.dt * np.arange(arr["q"].size)
        meta = {
            "code": "YADE",
            "steps": int(t.size - 1),
            "phys": ans.get("phys", {}),
            **mp["scene"],
        }
        return Trajectory(t, arr["q"], arr["v"], arr["f"], meta)

    def _assembly_impl(self, request):
        if isinstance(request, LatticeRequest):  # periodic lattice (`_yade_lattice`)
            sc = lattice_scene(request)
            n = request.n_bodies * 3 * (int(request.n_steps) + 1)
            ans = self._ask({"op": "lattice", "scene": sc, "dt": request.dt,
                             "n_steps": int(request.n_steps),
                             "stop": request.stop_kinetic(1e12)}, n)  # fmt: skip
            return parse_lattice(ans, request, {"code": "YADE", "young": sc["young"],
                                                "density": sc["density"]})  # fmt: skip
        sc = chain_scene(request)
        n = request.n_bodies * (int(request.n_steps) + 1)
        # a runaway ends at its stop energy, at most 1e12 E_0 (the suite's MAX_FACTOR)
        stop = request.stop_kinetic(1e12)
        ans = self._ask({"op": "chain", "scene": sc, "dt": request.dt,
                         "n_steps": int(request.n_steps), "stop": stop}, n)  # fmt: skip
        return parse_chain(ans, request, {"code": "YADE", "young": sc["young"],
                                          "density": sc["density"]})  # fmt: skip

    def step_advice(self, request) -> dict:
        """``PWaveTimeStep()`` and ``GlobalStiffnessTimeStepper``'s smallest step (s)."""
        if isinstance(request, LatticeRequest):
            ans = self._ask({"op": "lattice_advice", "scene": lattice_scene(request),
                             "dt": request.dt, "n_steps": int(request.n_steps)}, 4)  # fmt: skip
            return parse_advice(ans)
        ans = self._ask({"op": "chain_advice", "scene": chain_scene(request),
                         "dt": request.dt, "n_steps": int(request.n_steps)}, 4)  # fmt: skip
        return parse_advice(ans)

    def probe_forces(self, scene: AdapterScene, states) -> tuple[np.ndarray, dict]:
        """Force (N, + repulsive) YADE computes at each (overlap, dq/dt) state, and its
        contact physics (kn, cn, kno, betan as YADE stores them).

        Each state is built afresh and stepped once: the force of that step is the
        one at the placed position with the placed velocity (the velocity the
        dashpot uses, see the staggering in the module docstring).
        """
        mp = self.mapping(scene)
        states = [[float(d), float(r)] for d, r in states]
        ans = self._ask({"op": "probe", "scene": mp["scene"], "states": states}, len(states))
        return np.array(ans["f"], dtype=float), ans.get("phys", {})

    def close(self) -> None:
        if self._server is not None:
            self._server.close()
