"""The adapter contract: how a third-party contact code is plugged into the suite.

The suite benchmarks other people's contact codes by running the same normal
impacts through them and through the exact solution (`reference_impl.solve_impact`),
then comparing. A code is plugged in through an *adapter*: a subclass of
`ContactAdapter` (Python), or a command speaking JSON on stdin/stdout
(`reference_impl.adapters.subprocess`, schema in ``docs/adapter-protocol.md``).

Implementer contract
--------------------
The items hold for both forms; where the JSON form of a ``cmd:`` program
differs, the item says so (``docs/adapter-protocol.md`` has its full schema).

1. Subclass `ContactAdapter`, give it a short ``name`` and implement
   ``_impact_impl(self, scene: AdapterScene) -> Trajectory`` (a mapping with the
   keys ``t, q, v, force`` and optionally ``meta`` is accepted too). Do not
   override `ContactAdapter.impact`: it validates what you return. Run it with
   ``hcv bench package.module:Class`` (constructor arguments
   ``package.module:Class[key=value,...]``); a program in another language with
   ``hcv bench "cmd:COMMAND"`` (one JSON request on stdin, one JSON response on
   stdout per run).
2. What a scene gives (`AdapterScene`, SI units): the contact potential U(q)
   (``potential``, a `Potential`; ``potential_spec`` is the same as a plain dict,
   e.g. ``{"family": "power", "k": 1e10, "p": 1.5}`` for U' = k q^p), the
   *effective* mass ``mass`` (kg), the approach speed ``v0`` (m/s, > 0), the
   damping asked for (``damping`` = "none" or "universal" with ratio ``zeta``, i.e.
   C(q) = 2 zeta sqrt(m) U'/sqrt(2U), whose restitution is ``restitution`` at every
   speed, or another law of `reference_impl.theory.laws`; ``law`` is the law with
   its solved parameters, e.g. ``{"law": "hunt-crossley", "alpha": 0.31}``, and
   ``restitution_asked`` the e the scene asks at ``restitution_end``, for a
   speed-dependent law at ``restitution_speed``), the time step ``dt`` (s) and a
   step budget ``n_steps``; ``velocities`` lists every speed of the scene (for codes
   that calibrate a damping constant). A code that integrates the universal law only
   declines other laws (item 7; `AdapterScene.universal_only` words the reason).
   ``cmd:``: the ``"scene"`` object of the request (`AdapterScene.to_json`).
3. Start at contact onset: t = 0, overlap q = 0, dq/dt = v0 (q > 0 is overlap,
   dq/dt > 0 approaching). For two bodies, q is the total overlap and ``mass``
   the reduced mass m1 m2 / (m1 + m2).
4. Integrate with exactly ``scene.dt`` and record every step. Stop at the first
   step after the overlap has returned to q <= 0 (the body has separated), or
   after ``scene.n_steps`` steps, whichever comes first. Keep that first
   out-of-contact sample: the restitution is read from its velocity.
5. Return 1-D float arrays of equal length >= 2: time ``t`` (s, t[0] = 0,
   strictly increasing), overlap ``q`` (m; <= 0 is a gap), its rate ``v`` (m/s)
   and the normal contact ``force`` on the body (N, positive = repulsive,
   negative = attractive, 0 out of contact), all at the same instants. A blown-up
   run may contain inf/NaN: that is a result (unstable), not malformed output.
   Anything else (missing key, wrong length, t not increasing) is malformed and
   the run fails with a one-line reason. ``cmd:``: JSON arrays, non-finite
   numbers as ``null``.
6. Optional: ``implemented_law(scene) -> ImplementedLaw`` says which force law the
   code *actually* integrates (potential, mass, damping: a universal ratio
   ``zeta`` or a coefficient ``C(q)``, e.g. `PowerDamping`, or any law of
   `reference_impl.theory.laws` as a `LawDamping` (built by
   `reference_impl.adapters.implemented_law_from_table`); ``clips_tension`` if
   the code never lets the total force pull). The scorecard compares the code with
   the exact solution of that law as well as with what was asked; the references
   (exact solution, textbook Verlet) run every law of the table, not an opaque
   callable. The default claims the scene's own law. For adapters run in a worker
   process the law is pickled: use `LawDamping`, `PowerDamping` or a module-level
   function for ``C``. ``cmd:``: the ``"implemented_law"`` key of the response.
7. Declining a scene. Optional: ``supports(scene) -> str | None`` returns why a
   scene cannot be run (e.g. "only power laws with p = 1 or 1.5"); such scenes
   are skipped, not failed. A code that finds out only while running raises
   `AdapterDeclined` ("one-line reason") from ``_impact_impl`` /
   ``_sustained_impl``: the whole scene is skipped with that reason. A ``cmd:``
   program answers ``{"unsupported": "one-line reason"}`` instead of a
   trajectory (``{"error": "..."}`` or a non-zero exit is a failed run, not a skip).
8. Optional: ``variants() -> list[ContactAdapter]`` splits one adapter into
   several configurations benchmarked separately (e.g. one per damping model);
   each variant needs a distinct ``label``.
9. Optional, sustained scenes (kind "two-walls"), sent only to adapters that
   declare them (undeclared: skipped, "runs single impacts only"). Python: set
   ``supports_sustained = True`` and implement ``_sustained_impl(scene)``, which
   returns the trajectory of ``scene.n_steps`` steps of a body bouncing between
   two walls ``scene.gap`` apart (q measured at the wall being touched, as in
   `reference_impl.integrators.verlet`). ``cmd:`` program: give it as
   ``cmd[sustained=true]:COMMAND`` and answer requests with ``"request":
   "sustained"`` the same way (or decline one, item 7).
10. Be deterministic and self-contained: no files left behind, nothing printed on
    stdout (use stderr for diagnostics; it is kept and shown when a run fails; a
    Python adapter's stdout is discarded with one warning naming it, a ``cmd:``
    program's stdout is its JSON answer). A run that raises, crashes or exceeds
    the per-run timeout is reported as a failure of that run only; the benchmark
    goes on (after a timeout, the code's other runs on that scene are not started).
11. Staggered quantities. Report q, v and force at the same instants t[n] when
    you can. A code that stores some of them shifted in time may return them as
    stored and declare the shift in ``staggering`` (a mapping, class or instance
    attribute; the ``"staggering"`` key of a ``cmd:`` response does the same):
    ``{"force": k}`` (integer k, 1 to 4) when force[n] is the force at t[n - k] (a
    force stored one step late, e.g. Kratos' Symplectic_Euler: k = 1);
    ``{"v": 0.5}`` when v[n] is the velocity at t[n] - dt/2 (leapfrog). `impact`
    re-aligns before anything is measured: force[n] <- force[n + k] and
    v[n] <- (v[n] + v[n + 1]) / 2; the last k samples (last sample for v) keep 0
    force / their own velocity when out of contact (q <= 0), NaN otherwise. The
    run's ``meta["staggering_aligned"]`` records what was done.
12. Time-stepping scheme (class or instance attributes; `scheme_of` reads and checks
    them): ``time_scheme``, one of ``velocity-verlet`` (the default), ``symplectic-euler``,
    ``explicit-euler``, ``implicit-euler``, ``rk4`` (a higher-order method) or
    ``variable-step``; ``claimed_order``, the order the code claims (default the
    scheme's nominal order); a variable-step code gives ``scheme_rtol``, its error
    tolerance, and its ``dt`` is only its sampling (report its state at t = n dt from
    its own dense output). The implementation verdict then allows, at each step, the
    error the declared scheme itself makes on the declared law (the bench runs that
    scheme on the exact law), asks the step-refinement study for at least the order a
    correct code of that scheme shows, and its extrapolated answer to agree with the
    exact one.
13. Built-in codes only: ``code_info`` (a `CodeInfo`) says how the code takes a
    restitution (the input a user types), which variants the report's side-by-side
    section runs, its pip extra or Debian package, its pytest marker and its test
    module. The registry makes every list of codes from it, and
    ``verification/test_code_registry.py`` fails for a registered built-in adapter
    whose test module, marker, install line or docs row is missing.
14. Optional, assembly scenes (issue 39, a chain of spheres on a line: `ChainRequest`,
    geometry in `reference_impl.adapters._assembly_request`). Set
    ``supports_assembly = True`` and implement ``_assembly_impl(request) -> ChainRun``:
    the positions and velocities along x after every one of ``request.n_steps`` steps of
    ``request.dt`` (the suite computes the energy with the scene's law and decides a
    runaway with its own criterion). ``step_advice(request) -> dict`` gives the code's
    own time-step advice as the code computes it (name -> dt in s; empty: the code gives
    none). Undeclared, `ContactAdapter.assembly` declines in one line ("<code> does not
    run assembly scenes"), which ``hcv dt-crit SCENE --adapter CODE`` prints with exit
    status 2. A ``cmd:`` program declares them in its brackets,
    ``cmd[assembly=chain+lattice,advice=true]:COMMAND``, and answers JSON requests
    (`reference_impl.adapters._cmd_assembly`); undeclared, it declines.
    The same hook takes a periodic lattice (`LatticeRequest`, in
    `reference_impl.adapters._lattice_request`: 3-D positions in a rectangular box, the
    contact list, normal contacts only) and returns a `LatticeRun` (positions and
    velocities of shape (samples, N, 3)) when the adapter also sets ``supports_lattice =
    True``; else `ContactAdapter.assembly` declines it in one line ("<code> does not run
    lattice scenes"), so a chain code written before lattices never sees one.
"""

from __future__ import annotations

from collections.abc import Mapping

from reference_impl.adapters._assembly_request import (
    ChainRequest,
    ChainRun,
    chain_run_from_mapping,
)
from reference_impl.adapters._declaration import (
    SCHEMES,
    CodeInfo,
    Scheme,
    offset_refusal,
    scheme_of,
)
from reference_impl.adapters._lattice_request import (
    LatticeRequest,
    LatticeRun,
    lattice_run_from_mapping,
)
from reference_impl.adapters._output import (
    align_staggered,
    check_staggering,
    trajectory_from_mapping,
)
from reference_impl.adapters._records import (
    AdapterDeclined,
    AdapterError,
    AdapterOutputError,
    AdapterRunError,
    AdapterScene,
    ImplementedLaw,
    PowerDamping,
    Trajectory,
)
from reference_impl.adapters.law_damping import scene_law

__all__ = [
    "AdapterDeclined",
    "AdapterError",
    "AdapterOutputError",
    "AdapterRunError",
    "AdapterScene",
    "ChainRequest",
    "ChainRun",
    "CodeInfo",
    "ContactAdapter",
    "ImplementedLaw",
    "LatticeRequest",
    "LatticeRun",
    "PowerDamping",
    "SCHEMES",
    "Scheme",
    "Trajectory",
    "align_staggered",
    "check_staggering",
    "offset_refusal",
    "scheme_of",
    "trajectory_from_mapping",
]


class ContactAdapter:
    """Base class of every adapter; see the module docstring for the contract.

    Class attributes
    ----------------
    name : str
        Registry-style name of the code ("lammps", "reference", ...).
    spec_values : dict
        Constructor arguments a spec may give by value alone (``kratos[hertz,verlet]``):
        key -> accepted values; a ``True`` flag key is given by its own name
        (``lammps[tsuji,limit_damping]``). Listed by ``hcv bench --help``.
    isolate : bool
        Run this adapter in a worker process (crash and hang isolation). True by
        default for third-party code; adapters that are themselves isolated (the
        subprocess adapter) or trusted (the reference) set it False.
    supports_sustained : bool
        Implements `_sustained_impl` (contract item 9).
    supports_assembly : bool
        Implements `_assembly_impl` (contract item 14: chain scenes).
    supports_lattice : bool
        Its `_assembly_impl` also takes a `LatticeRequest` (contract item 14).
    staggering : dict
        Time shifts of the returned samples (contract item 11), e.g. {"force": 1}
        when the force is stored one step late; `impact` re-aligns them. Empty:
        every quantity is at t[n].
    time_scheme, claimed_order, scheme_rtol
        The time-stepping scheme, the order claimed and a variable-step code's
        tolerance (contract item 12; `scheme_of`).
    code_info : CodeInfo or None
        A built-in code's declaration for the registry (contract item 13).
    """

    name: str = "adapter"
    spec_values: Mapping = {}
    isolate: bool = True
    supports_sustained: bool = False
    supports_assembly: bool = False
    supports_lattice: bool = False
    staggering: Mapping = {}
    time_scheme: str = "velocity-verlet"
    claimed_order: float | None = None
    scheme_rtol: float | None = None
    force_offset: float = 0.0
    code_info: CodeInfo | None = None

    @property
    def label(self) -> str:
        """Name of this configuration in scorecards (unique among `variants`)."""
        return self.name

    # -- the hooks an implementer provides -----------------------------------
    def _impact_impl(self, scene: AdapterScene):  # pragma: no cover - abstract
        raise NotImplementedError(f"{type(self).__name__} must implement _impact_impl(scene)")

    def _sustained_impl(self, scene: AdapterScene):
        raise NotImplementedError(f"{type(self).__name__} does not implement sustained scenes")

    def _assembly_impl(self, request: ChainRequest):
        raise NotImplementedError(f"{type(self).__name__} does not implement assembly scenes")

    def step_advice(self, request: ChainRequest | LatticeRequest) -> dict:
        """The code's own time-step advice for an assembly (name -> dt in s), as the code
        computes it (contract item 14); empty when the code gives none."""
        return {}

    def supports(self, scene: AdapterScene) -> str | None:
        """None when the scene can be run, else a one-line reason (the scene is skipped)."""
        if scene.kind != "impact" and not self.supports_sustained:
            return f"{self.label} runs single impacts only (scene kind {scene.kind!r})"
        return None

    def implemented_law(self, scene: AdapterScene) -> ImplementedLaw:
        """The law the code integrates for this scene; default: exactly the scene's
        (any damping law, with its solved parameters: `reference_impl.adapters.law_damping.scene_law`)."""
        return scene_law(scene, description="as asked (the adapter declares no other law)")

    def variants(self) -> list[ContactAdapter]:
        """Configurations benchmarked separately; default: this adapter alone."""
        return [self]

    def describe(self) -> dict:
        """Code name, version and settings (goes into the JSON report)."""
        return {"name": self.name, "label": self.label}

    # -- the public, validated interface ---------------------------------------
    def impact(self, scene: AdapterScene) -> Trajectory:
        """Run one normal impact and return the validated trajectory.

        Raises
        ------
        AdapterOutputError
            The output breaks the contract (one-line reason).
        """
        out = self._impact_impl(scene)
        return trajectory_from_mapping(out, who=self.label, staggering=self.staggering)

    def sustained(self, scene: AdapterScene) -> Trajectory:
        """Run one sustained scene (two-walls) and return the validated trajectory."""
        out = self._sustained_impl(scene)
        return trajectory_from_mapping(out, who=self.label, staggering=self.staggering)

    def assembly(self, request: ChainRequest | LatticeRequest) -> ChainRun | LatticeRun:
        """Run one chain or lattice (contract item 14); the validated positions and velocities.

        Raises
        ------
        AdapterDeclined
            The code does not run assembly scenes ("<code> does not run assembly scenes").
        AdapterOutputError
            The output breaks the contract (one-line reason).
        """
        if not self.supports_assembly:
            raise AdapterDeclined(f"{self.label} does not run assembly scenes")
        if isinstance(request, LatticeRequest) and not self.supports_lattice:
            raise AdapterDeclined(f"{self.label} does not run lattice scenes")
        out = self._assembly_impl(request)
        if isinstance(request, LatticeRequest):
            return lattice_run_from_mapping(out, request, who=self.label)
        return chain_run_from_mapping(out, request, who=self.label)

    def close(self) -> None:
        """Release resources (called once at the end of a benchmark)."""

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.label}>"
