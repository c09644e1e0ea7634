"""LIGGGHTS adapter: ``pair_style gran`` / ``fix wall/gran`` of the Debian ``liggghts`` program.

Install with ``apt-get install -y liggghts`` (Debian 12: LIGGGHTS-PUBLIC 3.8.0).
LIGGGHTS reads its input script on stdin; the trajectory comes back on stdout as
lines ``HCV q v f`` written by ``fix print`` after every step. One process serves
every run and variant (the persistent mode, `reference_impl.adapters._persistent`):
each run's script ends with ``print "HCVEND n"`` and ``clear`` (which resets the
whole simulation), and the adapter reads up to that marker. LIGGGHTS must then
flush its output per line: it runs under ``stdbuf -oL`` (its stdout is a pipe,
fully buffered otherwise, so the marker would never come). A LIGGGHTS ``ERROR``
ends the process; that run fails quoting the error line and the next run starts
a fresh process. ``persistent=false`` starts one process per run (~0.6 s each).

Scene -> LIGGGHTS (exact mapping, from the 3.8.0 sources)
---------------------------------------------------------
Geometry "wall": one sphere of radius R and mass m on ``fix wall/gran ...
primitive type 1 zplane 0.0``; R_eff = R, m_eff = m (``fix_wall_gran_base.h``
line 195: ``meff = mass``). Geometry "pair": two spheres of radius R and mass 2m
head-on; R_eff = R/2, m_eff = m. R defaults to 100 q_max (a 1 % overlap). The
wall has the particle's material (one atom type), Poisson ratio 0, so
Y_eff = 1 / ((1 - nu^2)/Y + (1 - nu^2)/Y) = Y/2 (``global_properties.cpp``
line 432).

``model hertz`` (``normal_model_hertz.h``, 3.8.0, lines 211-260)::

    kn     = 4/3 Yeff sqrt(reff deltan)                       (line 234)
    gamman = -2 sqrt(5/6) betaeff sqrt(Sn meff),  Sn = 2 Yeff sqrt(reff deltan)  (237)
    Fn     = kn deltan - gamman vn                            (253-255)
    if (limitForce && Fn < 0) Fn = 0                          (258)

with betaeff = ln e / sqrt(ln^2 e + pi^2) (``global_properties.cpp`` line 539),
e = ``coefficientRestitution``. So U' = k q^(3/2) with k = 4/3 Yeff sqrt(R_eff)
and C = 2 sqrt(5/6) (-betaeff) sqrt(3/2 k m) q^(1/4) = 2 zeta sqrt(m) U'/sqrt(2U)
with zeta = -betaeff: the paper's universal law, whose restitution at q = 0 is
exp(-pi zeta / sqrt(1 - zeta^2)) = e exactly, at every speed.

``model hooke`` (``normal_model_hooke.h``, 3.8.0, lines 236-291)::

    kn     = 16/15 sqrt(reff) Yeff (15 meff vc^2 / (16 sqrt(reff) Yeff))^(1/5)  (269)
    gamman = sqrt(4 meff kn ln^2 e / (ln^2 e + pi^2))        (274)
    Fn     = kn deltan - gamman vn,  limitForce as above     (281-291)

with vc = ``characteristicVelocity``: a linear spring k = kn and a constant
dashpot C = 2 zeta sqrt(m k), zeta = -ln e / sqrt(ln^2 e + pi^2): again the
universal law (p = 1). The adapter solves Yeff from the asked k (vc = 1 m/s).

Clipping: ``limitForce`` is off by default: the total force pulls at the end of
contact (measured: 6.8 % of the peak force on ``hertz-damped``, e = 0.729; 26 % on
``hooke-damped``, e = 0.5; 12.7 % for Hertz at e = 0.5) and the restitution at
q = 0 is e. ``limitForce on`` clips it (``clips_tension``), the body leaves at the
zero-force end and e comes out higher (0.55 for coefficientRestitution 0.5; no
coefficientRestitution reaches 0.2: the floor 0.05 gives 0.213).

What is typed (protocol ``hcv-adapter/2``; issue 40, §2): coefficientRestitution is the
asked e itself, as LIGGGHTS documents it and a user types it. Both models integrate the
universal law of that e, so with ``limitForce off`` a scene asking e at the overlap end
gets it; with ``limitForce on`` (or a scene asking at the zero-force end) what is
delivered differs, and the delivery verdict says by how much. The input that would
deliver the asked e is ``hcv calibrate liggghts[...] --param restitution``, a separate
answer. An asked e <= 0.05 (LIGGGHTS refuses such inputs) declines the scene.

Staggering: none to declare. LIGGGHTS is velocity Verlet (``fix nve/sphere``):
``fix print`` runs at the end of a step, when x, v and f all belong to t[n + 1];
the dashpot uses the half-step velocity of the force evaluation, as the
reference Verlet does.

Traps handled (found by maintainers wiring it by hand)
-------------------------------------------------------
* ``youngsModulus <= 1e9 required for SI units (use command 'hard_particles
  yes' to override)`` (``global_properties.cpp`` line 370-371): steel-like
  contacts need Y ~ 1e11, so the script always says ``hard_particles yes``.
* ``limitForce on`` is a keyword of the *model*: in ``fix wall/gran`` it goes
  after the wall definition (``... primitive type 1 zplane 0.0 limitForce on``),
  before it the fix refuses the line.
* ``0.05 < coefficientRestitution <= 1 required`` (``global_properties.cpp``
  line 488-489): scenes asking e <= 0.05 are declined with that reason.
* A body touching at deltan = 0 gets no force: the first force is at step 1.
"""

from __future__ import annotations

import math
import shutil
import subprocess

import numpy as np

from reference_impl.adapters._codes_common import (
    bool_option,
    default_radius,
    positive_option,
    refuse_scene,
    split_option,
)
from reference_impl.adapters._declaration import CodeInfo
from reference_impl.adapters._lattice_request import LatticeRequest
from reference_impl.adapters._liggghts_chain import (
    chain_advice_script,
    chain_mapping,
    chain_script,
    parse_advice,
    parse_chain,
)
from reference_impl.adapters._liggghts_lattice import (
    lattice_advice_script,
    lattice_mapping,
    lattice_script,
    parse_lattice,
)
from reference_impl.adapters._persistent import PersistentProcess
from reference_impl.adapters.base import (
    AdapterDeclined,
    AdapterRunError,
    AdapterScene,
    ContactAdapter,
    ImplementedLaw,
    Trajectory,
)
from reference_impl.errors import HCVInputError

__all__ = [
    "GEOMETRIES",
    "MODELS",
    "LiggghtsAdapter",
    "liggghts_available",
    "liggghts_zeta",
]

MODELS = ("hertz", "hooke")
GEOMETRIES = ("wall", "pair")
INSTALL = "apt-get install -y liggghts"
# characteristicVelocity of model hooke (m/s): any value, Yeff is solved for it.
_CHAR_VEL = 1.0
# LIGGGHTS refuses coefficientRestitution <= this (global_properties.cpp line 488).
_E_MIN = 0.05
# Seconds allowed to one liggghts process when the adapter runs outside a bench
# (the bench's worker has its own per-run timeout).
_TIMEOUT = 600.0
_ARGS = ("-echo", "none", "-log", "none")
# The version probe: help text, and no log.liggghts left in the caller's directory.
_HELP_ARGS = ("-log", "none", "-h")
# What `liggghts -h` said, once per process (the version line).
_PROGRAM: dict = {}
# Output bound of one run in the persistent mode (bytes): ~70 per step of fix print.
_MAX_OUTPUT = 64 << 20


def liggghts_available() -> str | None:
    """None when the ``liggghts`` program is on PATH, else a one-line reason."""
    if shutil.which("liggghts") is None:
        return f"LIGGGHTS is not installed; install it with {INSTALL} (Debian/Ubuntu)"
    return None


def liggghts_zeta(e: float) -> float:
    """-betaeff = -ln e / sqrt(ln^2 e + pi^2): the universal law's zeta LIGGGHTS integrates."""
    if e >= 1.0:
        return 0.0
    le = math.log(e)
    return -le / math.sqrt(le * le + math.pi**2)


class LiggghtsAdapter(ContactAdapter):
    """Head-on normal impacts in LIGGGHTS (see the module docstring for the law).

    Parameters
    ----------
    model : str, optional
        "hertz", "hooke", joined by "+", or "all" (default: both).
    geometry : str, optional
        "wall", "pair" or "wall+pair" (default "wall").
    limit_force : bool, optional
        ``limitForce on`` (no attractive total normal force). Default off;
        variants with it off and on when no option is given.
    radius : float, optional
        Sphere radius R (m); default 100 q_max at the scene's largest speed.
    restitution : float, optional
        ``coefficientRestitution`` written instead of the scene's e (0.05 < e <= 1):
        what ``hcv calibrate liggghts[...] --param restitution`` searches.
    persistent : bool
        One LIGGGHTS process for every run (default); False: one per run.

    Without options the variants are hertz and hooke on the wall with
    ``limitForce`` off and on, and hertz between two spheres.
    """

    name = "liggghts"
    isolate = True
    # contract item 14: Hertz chains and periodic lattices (`_liggghts_chain`, `_liggghts_lattice`)
    supports_assembly = True
    supports_lattice = True
    spec_values = {"model": MODELS, "geometry": GEOMETRIES, "limit_force": True}
    # contract item 13: what the registry, the report and CI know of LIGGGHTS
    code_info = CodeInfo(
        code="LIGGGHTS",
        restitution_input="fix property/global coefficientRestitution peratomtypepair: e",
        report_variants=(
            ("liggghts[hertz,wall]", 1.5),
            ("liggghts[hertz,wall,limit_force=true]", 1.5),
        ),
        calibrated=(("liggghts[model=hertz,geometry=wall,limit_force=true]", 1.5, "restitution"),),
        apt="liggghts",
        marker="liggghts",
        test_module="verification/test_liggghts.py",
    )

    def __init__(
        self,
        model: str | None = None,
        geometry: str | None = None,
        limit_force: bool | None = None,
        radius: float | None = None,
        restitution: float | None = None,
        persistent: bool = True,
    ):
        reason = liggghts_available()
        if reason:
            raise HCVInputError(f"adapter liggghts: {reason}")
        self._default_set = model is None and geometry is None and limit_force is None
        self.models = split_option("liggghts", "model", model, MODELS)
        geometry = "wall" if geometry is None else geometry
        self.geoms = split_option("liggghts", "geometry", geometry, GEOMETRIES)
        bool_option("liggghts", "limit_force", limit_force)
        # both settings as variants only when nothing is configured (the default set)
        self.limits = (
            ((False, True) if self._default_set else (False,))
            if limit_force is None
            else (limit_force,)
        )
        self.radius = positive_option("liggghts", "radius", radius)
        if restitution is not None and not (
            isinstance(restitution, (int, float))
            and not isinstance(restitution, bool)
            and _E_MIN < restitution <= 1.0
        ):
            raise HCVInputError(
                f"adapter liggghts: restitution must be in ({_E_MIN:g}, 1] (LIGGGHTS refuses "
                f"others), got {restitution!r}"
            )
        self.restitution = None if restitution is None else float(restitution)
        self._version: str | None = None
        bool_option("liggghts", "persistent", persistent)
        # stdbuf (coreutils) makes LIGGGHTS flush per line; without it: one process per run
        self.persistent = persistent and shutil.which("stdbuf") is not None
        self._server = None

    # -- configuration ----------------------------------------------------------
    @property
    def single(self) -> bool:
        return len(self.models) == 1 and len(self.geoms) == 1 and len(self.limits) == 1

    @property
    def label(self) -> str:
        if not self.single:
            return "liggghts"
        extra = ",limit_force" if self.limits[0] else ""
        if self.restitution is not None:
            extra += f",restitution={self.restitution!r}"
        return f"liggghts[{self.models[0]},{self.geoms[0]}{extra}]"

    @classmethod
    def calibration_range(cls, param: str, scene) -> tuple[float, float] | None:
        """Search range of ``hcv calibrate``: coefficientRestitution over all LIGGGHTS takes."""
        return (_E_MIN * (1.0 + 1e-9), 1.0) if param == "restitution" else None

    def variants(self) -> list[ContactAdapter]:
        if self.single:
            return [self]
        combos = [(m, g, lim) for g in self.geoms for m in self.models for lim in self.limits]
        if self._default_set:
            combos.append(("hertz", "pair", False))
        out = [
            LiggghtsAdapter(
                model=m,
                geometry=g,
                limit_force=lim,
                radius=self.radius,
                restitution=self.restitution,
                persistent=self.persistent,
            )
            for m, g, lim in combos
        ]
        for v in out:
            v._server = self._shared_server()  # one LIGGGHTS process for every variant
        return out

    def _shared_server(self):
        if self._server is None:
            self._server = PersistentProcess(
                ["stdbuf", "-oL", "liggghts", *_ARGS], label="liggghts", startup_timeout=60.0
            )
        return self._server

    def _run(self, script: str) -> str:
        """stdout of ``script`` run by LIGGGHTS (the shared process, or a fresh one)."""
        if not self.persistent:
            return _run_liggghts(script)
        server = self._shared_server()
        marker = f"HCVEND {server.new_id()}"  # a fresh random number: no stale end line matches
        payload = f'{script}print "{marker}"\nclear\n'.encode()
        lines = server.exchange(
            payload, lambda ln: ln == marker.encode(), timeout=_TIMEOUT, limit=_MAX_OUTPUT
        )
        out = "\n".join(ln.decode(errors="replace") for ln in lines[:-1])
        err = next((ln for ln in out.splitlines() if ln.startswith("ERROR")), None)
        if err:  # pragma: no cover - LIGGGHTS exits on ERROR (caught by exchange)
            raise AdapterRunError(f"liggghts: {err}", out[-4000:])
        return out

    def close(self) -> None:
        if self._server is not None:
            self._server.close()

    @property
    def version(self) -> str:
        """The program's version line, e.g. "LIGGGHTS-PUBLIC 3.8.0"."""
        if self._version is None:
            if "version" not in _PROGRAM:  # one `liggghts -h` per process, not per variant
                # -log none: without it LIGGGHTS writes log.liggghts into the user's cwd
                out = _run_liggghts("", timeout=60.0, args=_HELP_ARGS)
                head = next((ln for ln in out.splitlines() if "Version" in ln), "")
                _PROGRAM["version"] = head.split("Version", 1)[-1].split(",")[0].strip()
            self._version = _PROGRAM["version"] or "unknown"
        return self._version

    def describe(self) -> dict:
        d = {
            "name": self.name,
            "label": self.label,
            "model": list(self.models),
            "geometry": list(self.geoms),
            "limit_force": list(self.limits),
        }
        try:
            d["version"] = self.version
        except AdapterRunError:  # pragma: no cover - the program broke after the check
            pass
        return d

    def supports(self, scene: AdapterScene) -> str | None:
        want = 1.5 if self.models[0] == "hertz" else 1.0
        reason = refuse_scene(
            self,
            scene,
            configure="model, geometry and limit_force",
            powers=(want,),
            no_power=f"LIGGGHTS model {self.models[0]} is U' = k q^{want:g}; scene potential "
            f"{scene.potential!r} has no equivalent in it",
        )
        if reason:
            return reason
        e_in = self.mapping(scene)["coefficientRestitution"]
        if self.restitution is None and e_in <= _E_MIN:
            return (
                f"LIGGGHTS refuses coefficientRestitution <= {_E_MIN:g} (asked e = "
                f"{e_in:.6g} at the {scene.restitution_end} end, typed as is); out of its reach"
            )
        return None

    # -- the mapping ------------------------------------------------------------
    def mapping(self, scene: AdapterScene) -> dict:
        """LIGGGHTS inputs for one scene: R, atom mass, Y, e, vc (see the module docstring)."""
        pot, m = scene.potential, scene.mass
        model, geom = self.models[0], self.geoms[0]
        R = default_radius(scene, self.radius)
        r_eff = R if geom == "wall" else 0.5 * R
        if model == "hertz":
            y_eff = 0.75 * pot.k / math.sqrt(r_eff)
        else:  # kn = (A Yeff)^(4/5) (m vc^2)^(1/5), A = 16/15 sqrt(reff): solved for Yeff
            y_eff = pot.k**1.25 / (m * _CHAR_VEL**2) ** 0.25 / (16.0 / 15.0 * math.sqrt(r_eff))
        return {
            "model": model,
            "geometry": geom,
            "R": float(R),
            "R_eff": float(r_eff),
            "atom_mass": float(m if geom == "wall" else 2.0 * m),
            "youngsModulus": float(2.0 * y_eff),  # Yeff = Y/2: same material, nu = 0
            "poissonsRatio": 0.0,
            "coefficientRestitution": float(
                self._typed_restitution(scene) if self.restitution is None else self.restitution
            ),
            "characteristicVelocity": _CHAR_VEL,
            "limitForce": "on" if self.limits[0] else "off",
        }

    def _typed_restitution(self, scene: AdapterScene) -> float:
        """The coefficientRestitution a user types: the asked e itself (1 without damping),
        as LIGGGHTS documents it (issue 40, §2). With ``limitForce on`` the contact leaves
        at the zero-force end and delivers more (0.55 for 0.5): the delivery verdict says
        so, and ``hcv calibrate`` finds the input that would deliver the asked e."""
        return float(scene.restitution_asked) if scene.damping != "none" else 1.0

    def implemented_law(self, scene: AdapterScene) -> ImplementedLaw:
        mp = self.mapping(scene)
        e = mp["coefficientRestitution"]
        zeta = liggghts_zeta(e)
        src = (
            "normal_model_hertz.h:234-258"
            if mp["model"] == "hertz"
            else "normal_model_hooke.h:269-291"
        )
        return ImplementedLaw(
            scene.potential,
            scene.mass,
            zeta=zeta,
            clips_tension=self.limits[0],
            description=(
                f"{mp['model']}, coefficientRestitution = {e:.6g}: universal law, zeta = "
                f"-betaeff = {zeta:.6g}, limitForce {mp['limitForce']} ({src})"
            ),
            params={**mp, "version": self.version},
        )

    # -- running LIGGGHTS -----------------------------------------------------------
    def script(
        self, scene: AdapterScene, delta0: float = 0.0, rate: float | None = None, steps: int = 0
    ) -> str:
        """Input script of one run: the body starts at overlap delta0 with dq/dt = rate."""
        mp = self.mapping(scene)
        R, v0 = mp["R"], scene.v0 if rate is None else rate
        box = 4.0 * R
        model = f"model {mp['model']} tangential no_history"
        limit = f" limitForce {mp['limitForce']}"
        head = (
            "atom_style granular\natom_modify map array\nboundary m m m\nnewton off\n"
            "communicate single vel yes\nunits si\n"
            # Y > 1e9 Pa is refused in SI units without this (global_properties.cpp:370)
            "hard_particles yes\n"
            f"region reg block {-box!r} {box!r} {-box!r} {box!r} {-box!r} {box!r} units box\n"
            "create_box 1 reg\n"
            f"neighbor {0.5 * R!r} bin\nneigh_modify delay 0\n"
            f"fix m1 all property/global youngsModulus peratomtype {mp['youngsModulus']!r}\n"
            f"fix m2 all property/global poissonsRatio peratomtype {mp['poissonsRatio']!r}\n"
            "fix m3 all property/global coefficientRestitution peratomtypepair 1 "
            f"{mp['coefficientRestitution']!r}\n"
            "fix m4 all property/global coefficientFriction peratomtypepair 1 0.0\n"
            "fix m5 all property/global characteristicVelocity scalar "
            f"{mp['characteristicVelocity']!r}\n"
            f"pair_style gran {model}" + (limit if mp["geometry"] == "pair" else "") + "\n"
            "pair_coeff * *\n"
            f"timestep {scene.dt!r}\n"
        )
        if mp["geometry"] == "wall":
            body = (
                # limitForce must come after the wall definition, else the fix refuses it
                f"fix wall all wall/gran {model} primitive type 1 zplane 0.0{limit}\n"
                f"create_atoms 1 single 0.0 0.0 {R - delta0!r} units box\n"
                f"set atom 1 diameter {2.0 * R!r}\nset atom 1 mass {mp['atom_mass']!r}\n"
                f"velocity all set 0.0 0.0 {-v0!r} units box\n"
                f"variable q equal {R!r}-z[1]\nvariable v equal -vz[1]\nvariable f equal fz[1]\n"
            )
        else:
            half = 0.5 * delta0
            body = (
                f"create_atoms 1 single 0.0 0.0 {-R + half!r} units box\n"
                f"create_atoms 1 single 0.0 0.0 {R - half!r} units box\n"
                f"set atom 1 diameter {2.0 * R!r}\nset atom 2 diameter {2.0 * R!r}\n"
                f"set atom 1 mass {mp['atom_mass']!r}\nset atom 2 mass {mp['atom_mass']!r}\n"
                f"velocity all set 0.0 0.0 0.0 units box\n"
                f"set atom 1 vz {0.5 * v0!r}\nset atom 2 vz {-0.5 * v0!r}\n"
                f"variable q equal {2.0 * R!r}-(z[2]-z[1])\nvariable v equal vz[1]-vz[2]\n"
                "variable f equal fz[2]\n"
            )
        tail = "fix int all nve/sphere\nthermo 0\n"
        if steps:
            tail += f'fix pr all print 1 "HCV ${{q}} ${{v}} ${{f}}" screen yes title none\nrun {steps}\n'
        else:
            tail += 'run 0\nprint "HCV ${q} ${v} ${f}"\n'
        return head + body + tail

    def _impact_impl(self, scene: AdapterScene) -> Trajectory:
        reason = self.supports(scene)
        if reason:
            raise AdapterDeclined(reason)
        rows = _hcv_rows(self._run(self.script(scene, steps=int(scene.n_steps))))
        # the onset sample (q = 0, v0, no force at deltan = 0), then one row per step
        data = np.vstack([[0.0, scene.v0, 0.0], rows])
        q, v, f = data[:, 0], data[:, 1], data[:, 2]
        k = _first_separation(q)
        t = scene.dt * np.arange(k)
        return Trajectory(
            t,
            q[:k],
            v[:k],
            f[:k],
            {"code": f"LIGGGHTS {self.version}", "steps": int(k - 1), **self.mapping(scene)},
        )

    def _assembly_impl(self, request):
        if isinstance(request, LatticeRequest):  # periodic lattice (`_liggghts_lattice`)
            mp = lattice_mapping(request)
            meta = {"code": f"LIGGGHTS {self.version}", **mp, "v_staggering": 0.0}
            return parse_lattice(self._run(lattice_script(request, mp)), request, meta)
        mp = chain_mapping(request)
        meta = {"code": f"LIGGGHTS {self.version}", **mp, "v_staggering": 0.0}
        return parse_chain(self._run(chain_script(request, mp)), request, meta)

    def step_advice(self, request) -> dict:
        """``fix check/timestep/gran``'s Rayleigh and Hertz times (s) of the assembly's start."""
        if isinstance(request, LatticeRequest):
            script = lattice_advice_script(request, lattice_mapping(request))
            return parse_advice(self._run(script), request.dt)
        return parse_advice(self._run(chain_advice_script(request, chain_mapping(request))),
                            request.dt)  # fmt: skip

    def probe_forces(self, scene: AdapterScene, states) -> np.ndarray:
        """Total normal force (N, + repulsive) LIGGGHTS applies at each (overlap, dq/dt) state.

        One process: the body is placed at each state in turn and ``run 0``
        computes the force there (the wall fix and the pair style compute it in
        ``setup``): a direct measurement of the law, compared with the declared
        one in the tests.
        """
        states = [(float(d), float(r)) for d, r in states]
        if not states:
            return np.empty(0)
        mp = self.mapping(scene)
        R = mp["R"]
        lines = []
        for delta, rate in states:
            if mp["geometry"] == "wall":
                lines.append(
                    f"set atom 1 x 0.0 y 0.0 z {R - delta!r}\n"
                    f"velocity all set 0.0 0.0 {-rate!r} units box\n"
                )
            else:
                lines.append(
                    f"set atom 1 x 0.0 y 0.0 z {-R + 0.5 * delta!r}\n"
                    f"set atom 2 x 0.0 y 0.0 z {R - 0.5 * delta!r}\n"
                    f"set atom 1 vx 0.0 vy 0.0 vz {0.5 * rate!r}\n"
                    f"set atom 2 vx 0.0 vy 0.0 vz {-0.5 * rate!r}\n"
                )
            lines.append('run 0\nprint "HCV ${q} ${v} ${f}"\n')
        script = self.script(scene, delta0=states[0][0], rate=states[0][1])
        script = script[: script.rindex("run 0")] + "".join(lines)
        rows = _hcv_rows(self._run(script))
        if rows.shape[0] != len(states):
            raise AdapterRunError(
                f"liggghts printed {rows.shape[0]} forces for {len(states)} states"
            )
        return rows[:, 2].copy()

    def probe_force(self, scene: AdapterScene, delta: float, rate: float) -> float:
        """`probe_forces` at one state (N)."""
        return float(self.probe_forces(scene, [(delta, rate)])[0])


def _first_separation(q: np.ndarray) -> int:
    """Samples up to and including the first one back at q <= 0 after contact."""
    inside = np.flatnonzero(q > 0)
    if inside.size == 0:
        return q.size
    out = np.flatnonzero(q[inside[0] :] <= 0)
    return q.size if out.size == 0 else int(inside[0] + out[0] + 1)


def _run_liggghts(script: str, timeout: float = _TIMEOUT, args: tuple = _ARGS) -> str:
    """stdout of one ``liggghts`` process fed ``script``; AdapterRunError on an error."""
    try:
        r = subprocess.run(
            ["liggghts", *args],
            input=script,
            capture_output=True,
            # LIGGGHTS' error messages can carry stray bytes (uninitialised memory): replace
            encoding="utf-8",
            errors="replace",
            timeout=timeout,
            start_new_session=True,
        )
    except FileNotFoundError:
        raise AdapterRunError(f"LIGGGHTS is not installed; {INSTALL}") from None
    except subprocess.TimeoutExpired as exc:
        raise AdapterRunError(
            f"liggghts did not finish in {timeout:g} s", str(exc.stderr or "")
        ) from None
    err = next((ln for ln in r.stdout.splitlines() if ln.startswith("ERROR")), None)
    if err or (r.returncode != 0 and args == _ARGS):
        raise AdapterRunError(
            f"liggghts: {err or f'exit status {r.returncode}'}", (r.stdout + r.stderr)[-4000:]
        )
    return r.stdout


def _hcv_rows(out: str) -> np.ndarray:
    """The ``HCV q v f`` lines of a run as an (n, 3) array."""
    rows = [ln.split()[1:4] for ln in out.splitlines() if ln.startswith("HCV ")]
    if not rows:
        raise AdapterRunError("liggghts printed no trajectory", out[-4000:])
    try:
        return np.array(rows, dtype=float)
    except ValueError:
        raise AdapterRunError("liggghts printed a malformed trajectory line", out[-4000:]) from None
