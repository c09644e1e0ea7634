"""The contact codes on chains and lattices: their measured Delta t_crit and their step advice.

Issue 39, section 4. A code that runs assembly scenes (contract item 14 of
`reference_impl.adapters.base`: LIGGGHTS, YADE) runs a Hertz chain of N spheres between
two walls (the ``chain-hertz`` scene with its n set to N) at one step for a number of
steps and hands back positions and velocities; the suite computes the energy with the
scene's own law (`reference_impl.adapters._assembly_request.chain_energy`) and decides a
runaway with its own rule, `EnergyGrowth` (E_n > factor E_0 within the horizon, confirmed
by factor x confirm_factor E_0 within confirm_horizon horizons, or blown), exactly as its
assembly kernel does. The bracket search over dt is the suite's (`search_steps`: scan,
extension, k-section), on a coarse grid (`CODE_GRID`: the codes start slowly, each step
tried is one run). Beside it, the suite's own search of the same scene, horizon, rule and
grid on the unperturbed lane (`reference_impl.assembly.search.search_ensemble`, one lane):
both integrate velocity Verlet (YADE's leapfrog has the same positions), so the two agree
unless the code's law or scheme differs.

The codes' advice, as each code computes it (`ContactAdapter.step_advice`): LIGGGHTS
``fix check/timestep/gran`` (the Rayleigh time and the Hertz time), YADE
``PWaveTimeStep()`` and ``GlobalStiffnessTimeStepper``; LAMMPS computes none. The verdict:
safe when advice <= measured Delta t_crit, and the factor Delta t_crit / advice (above 1:
the advice is below the critical step by that factor; below 1: using the advice itself
runs away, and it must be reduced by that factor). The Rayleigh and P-wave times are
meant to be used as a fraction (users take 10-50 % of them); the table gives the time
itself and the factor says which fraction is safe.

Lattices (``lattices=True`` in `assembly_codes_table`, `LATTICE_SIZES`): the periodic ones
whose box is a rectangle (`CODE_LATTICES`), Hertz normal contacts only; `lattice_request`
hands a code the suite's own bodies in the suite's order
(`reference_impl.assembly.geometry.lattice_sites`), contact list and initial velocities
(`reference_impl.assembly.model.assembly_model`; a 2-D lattice in one plane of the codes'
3-D space), and refuses in one line a scene that asks more (tangential springs, rotation,
bonds, a gap, damping, walls) or a skewed box (triangular, honeycomb).

A code that asks for isolation (LAMMPS, LIGGGHTS) runs in a worker process of the bench
(`reference_impl.bench._code_worker.open_code`), as ``hcv bench`` runs it: a crash of its
library fails that code's rows, not the caller.

This lives in the bench layer because it runs adapters (the layering test keeps studies
below adapters). `assembly_codes_table` is the study; `code_dt_crit` one search.
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass

import numpy as np

from reference_impl.adapters._assembly_request import ChainRequest, chain_energy
from reference_impl.adapters._lattice_request import LatticeRequest, lattice_energy
from reference_impl.adapters.base import (
    AdapterDeclined,
    AdapterError,
    AdapterOutputError,
    ContactAdapter,
)
from reference_impl.adapters.registry import builtin_codes, resolve_class
from reference_impl.assembly.geometry import lattice_sites
from reference_impl.assembly.lanes import initial_energy
from reference_impl.assembly.model import assembly_model
from reference_impl.assembly.safe import dt_safe_conventions
from reference_impl.assembly.search import search_ensemble
from reference_impl.bench._code_worker import open_code
from reference_impl.errors import HCVInputError
from reference_impl.scenes import load_scene, scene_from_dict
from reference_impl.stability.criteria import EnergyGrowth, SearchGrid
from reference_impl.stability.steps import search_steps

__all__ = [
    "CODES",
    "CODE_LATTICES",
    "CODE_GRID",
    "CODE_HORIZON",
    "NO_ADVICE",
    "RADIUS",
    "AdviceRow",
    "CodeSearch",
    "assembly_codes_table",
    "chain_request",
    "code_energy",
    "code_request",
    "code_report",
    "chain_scene",
    "code_dt_crit",
    "judge_energy",
    "lattice_request",
    "lattice_scene",
]

# The codes of issue 39 (registry names): the built-in codes whose adapter runs chains
# (`ContactAdapter.supports_assembly`), in the registry's order; and the chain sizes.
CODES = tuple(n for n in builtin_codes() if resolve_class(n).supports_assembly)
SIZES = (2, 3, 4, 5)
# Sphere radius (m) of the chain: the hertz scene's 10 mm steel sphere, whose k = 1.0879e10
# N/m^1.5 and m = 4.1103 g the chain-hertz scene has (a chain scene has no radius; the
# codes need one for their geometry and their advice reads it).
RADIUS = 5e-3
# Steps of one code run: coarse, so that a search (~30 runs) stays within seconds; the
# suite's own numbers at 1e4 to 1e6 steps are `hcv dt-crit` on the scene.
CODE_HORIZON = 2000
# Scan 0.1 .. 2 Delta t_safe in steps of 0.1, refined to 1 % of Delta t_safe: ~30 runs.
CODE_GRID = SearchGrid(lo=0.1, hi=2.0, step=0.1, resolution=0.01, refine_points=4,
                       hi_max=8.0, lo_min=0.01)  # fmt: skip
# The step (in Delta t_safe) at which a code is asked for its advice: LIGGGHTS computes its
# Hertz time from the largest speed after one step, YADE's GlobalStiffnessTimeStepper starts
# from it; 1e-3 keeps the first step's state the start's to 1e-3 (the striker's speed).
ADVICE_DT = 1e-3
# What a code without step advice says (LAMMPS: its granular pair styles compute none).
NO_ADVICE = {"lammps": "LAMMPS computes no time-step advice for granular contacts"}
# The lattices the codes run (rectangular periodic box) and the cells of the table's
# scenes: 4 x 4 squares (16 bodies, Z = 4) and 3 x 3 x 3 cubes (27 bodies, Z = 6), the
# smallest boxes in which no body meets two images of one neighbour (cells >= 3), small
# enough that a code prints every body every step within seconds.
CODE_LATTICES = ("square", "simple-cubic", "bcc", "fcc")
LATTICE_SIZES = (("square", 4), ("simple-cubic", 3))
# Height of a 2-D layer's box (in R): not periodic, the spheres at its middle plane.
_LAYER_HEIGHT = 4.0


def chain_scene(n: int, base: str = "chain-hertz"):
    """The scene ``base`` (a chain) with ``n`` bodies (its other keys as they are)."""
    sc = load_scene(base)
    if sc.kind != "chain":
        raise HCVInputError(f"scene {base!r} is a {sc.kind}; the codes run chain scenes only")
    d = sc.to_dict()
    d.pop("source", None)  # where it was read from, not a key of the scene table
    d.update(n=int(n), name=f"{sc.name}-n{int(n)}")
    if isinstance(d.get("velocities"), list):
        raise HCVInputError(f"scene {base!r}: give the striker's speed, not a list, to resize it")
    return scene_from_dict(d)


def lattice_scene(lattice: str, cells: int, base: str = "lattice-hertz-triangular"):
    """The lattice scene ``base`` as the lattice ``lattice`` of ``cells`` cells (its law,
    mass, radius and striker as they are)."""
    sc = load_scene(base)
    if sc.kind != "lattice":
        raise HCVInputError(f"scene {base!r} is a {sc.kind}; give a lattice scene to resize")
    d = sc.to_dict()
    d.pop("source", None)  # where it was read from, not a key of the scene table
    d.update(lattice=lattice, cells=int(cells), name=f"lattice-hertz-{lattice}-{int(cells)}")
    return scene_from_dict(d)


def lattice_request(scene, dt: float, n_steps: int, stop_energy: float = math.inf):
    """The `LatticeRequest` of a periodic lattice scene at step ``dt`` (s), ``n_steps`` steps.

    Raises
    ------
    HCVInputError
        One line: no lattice, a skewed box, walls, a gap, bonded springs, damping,
        tangential springs or rotation (the codes run Hertz normal contacts only).
    """
    if scene.kind != "lattice":
        raise HCVInputError(f"scene {scene.name!r} is a {scene.kind}, not a lattice")
    f = scene.assembly
    who = f"scene {scene.name!r}"
    if f.lattice not in CODE_LATTICES:
        raise HCVInputError(f"{who}: the codes run lattices with a rectangular periodic box "
                            f"({', '.join(CODE_LATTICES)}), got {f.lattice!r}")  # fmt: skip
    if f.tangential_ratio > 0 or f.rotation:
        raise HCVInputError(f"{who}: the codes run normal contacts only; tangential_ratio "
                            f"{f.tangential_ratio!r} and rotation {f.rotation!r} are declined "
                            "(give 0 and false)")  # fmt: skip
    if not f.periodic or f.bonded or (scene.gap or 0.0) != 0.0 or scene.damping_law != "none":
        raise HCVInputError(f"{who}: the codes run periodic, touching, undamped, unbonded "
                            "lattices (periodic true, gap 0, bonded false, no [damping])")  # fmt: skip
    model = assembly_model(scene)
    a = model.assembly
    R = float(f.radius)
    sites, box = lattice_sites(f.lattice, f.cells, 2.0 * R)
    d = a.dim
    pos = np.zeros((a.n_bodies, 3))
    vel = np.zeros((a.n_bodies, 3))
    pos[:, :d] = sites
    vel[:, :d] = model.v_init
    full = np.full(3, _LAYER_HEIGHT * R)
    full[:d] = box
    if d == 2:
        pos[:, 2] = 0.5 * full[2]  # the layer's plane, in the middle of its slab
    # the shift of each contact: x_j + s - x_i = 2 R n at the sites
    shifts = np.zeros((a.n_contacts, 3))
    shifts[:, :d] = sites[a.ci] + 2.0 * R * a.normal - sites[a.cj]
    return LatticeRequest(
        name=scene.name,
        potential=scene.potential,
        masses=tuple(float(m) for m in a.mass),
        radius=R,
        positions=pos,
        velocities=vel,
        box=tuple(full.tolist()),
        periodic=(True, True, d == 3),
        contacts=np.column_stack([a.ci, a.cj]),
        shifts=shifts,
        dt=float(dt),
        n_steps=int(n_steps),
        stop_energy=float(stop_energy),
    )


def chain_request(
    scene, dt: float, n_steps: int, radius: float = RADIUS, stop_energy: float = math.inf
) -> ChainRequest:
    """The `ChainRequest` of a chain scene at step ``dt`` (s) for ``n_steps`` steps
    (``stop_energy``: J, where the code may end a runaway; `ChainRequest`).

    Raises
    ------
    HCVInputError
        The scene is no chain, has a gap or bonded springs, or asks damping (the codes'
        chains run touching, undamped, unbonded spheres).
    """
    if scene.kind != "chain":
        raise HCVInputError(f"scene {scene.name!r} is a {scene.kind}: the codes run chain "
                            "scenes only")  # fmt: skip
    f = scene.assembly
    if f.bonded or (scene.gap or 0.0) != 0.0 or scene.damping_law != "none":
        raise HCVInputError(f"scene {scene.name!r}: the codes run touching, undamped, unbonded "
                            "chains (gap 0, bonded false, no [damping])")  # fmt: skip
    model = assembly_model(scene)
    return ChainRequest(
        name=scene.name,
        potential=scene.potential,
        masses=tuple(float(m) for m in f.masses),
        radius=float(radius),
        walls=f.walls,
        velocities=tuple(float(v) for v in model.v_init[:, 0]),
        dt=float(dt),
        n_steps=int(n_steps),
        stop_energy=float(stop_energy),
    )


def code_request(scene, dt: float, n_steps: int, radius: float = RADIUS,
                 stop_energy: float = math.inf) -> ChainRequest | LatticeRequest:  # fmt: skip
    """The request of a chain (`chain_request`, spheres of ``radius``) or of a periodic
    lattice (`lattice_request`, the scene's radius)."""
    if scene.kind == "lattice":
        return lattice_request(scene, dt, n_steps, stop_energy)
    return chain_request(scene, dt, n_steps, radius, stop_energy)


def code_energy(req, out) -> np.ndarray:
    """The energy series (J) of a code's run with the scene's own law (chain or lattice)."""
    if isinstance(req, LatticeRequest):
        return lattice_energy(req, out)
    return chain_energy(req, out)


def judge_energy(e: np.ndarray, crit: EnergyGrowth) -> tuple[bool, str | None, float | None, bool]:
    """`EnergyGrowth`'s verdict on an energy series e[0..] (J), as the assembly kernel rules.

    Returns (failed, evidence "confirmed" | "domain" | None, peak E / E_0 of a bounded
    excursion or None, needs_more): a first crossing of factor E_0 within n_steps is
    followed on to confirm_steps steps from the start: a runaway if E also exceeds
    factor x confirm_factor E_0 (or the series turns non-finite: blown, "domain"),
    else bounded. ``needs_more`` is True when the series ends before that is decided
    (the caller runs the code for confirm_steps steps).
    """
    e0 = float(e[0])
    n = e.size - 1
    bad = np.flatnonzero(~np.isfinite(e))
    end = int(bad[0]) if bad.size else e.size  # samples before the series blew up
    over = np.flatnonzero(e[:end] > crit.factor * e0)
    first = int(over[0]) if over.size else None
    if first is None or first > crit.n_steps:
        if bad.size and int(bad[0]) <= crit.n_steps:
            return True, "domain", None, False
        return False, None, None, n < crit.n_steps
    level = crit.confirm_level * e0
    upto = min(end, crit.confirm_steps + 1)
    if np.any(e[first:upto] > level):
        return True, "confirmed", None, False
    if bad.size and int(bad[0]) <= crit.confirm_steps:
        return True, "domain", None, False
    if n < crit.confirm_steps:
        return False, None, None, True
    return False, None, float(np.max(e[:upto]) / e0), False


@dataclass(frozen=True)
class CodeSearch:
    """One code's Delta t_crit on one chain (s), by the suite's bracket search.

    Attributes
    ----------
    dt_crit, dt_stable : float
        Smallest failing step and the largest stable step below it (s); inf: none failed.
    evidence : str or None
        How the smallest failing step failed ("confirmed", "domain").
    runs, steps : int
        Code runs made, steps integrated over them.
    wall_s : float
        Wall-clock seconds of the search.
    """

    dt_crit: float
    dt_stable: float
    evidence: str | None
    runs: int
    steps: int
    wall_s: float


def code_dt_crit(
    adapter: ContactAdapter,
    scene,
    dt_ref: float,
    *,
    criterion: EnergyGrowth | None = None,
    grid: SearchGrid = CODE_GRID,
    radius: float = RADIUS,
) -> CodeSearch:
    """The code's Delta t_crit on a chain scene: the suite's search, the suite's criterion.

    Parameters
    ----------
    adapter : ContactAdapter
        A code that runs assembly scenes (contract item 14).
    scene : AssemblyScene
        A chain scene (`chain_request` says which).
    dt_ref : float
        Reference step of the scan (s), e.g. the scene's Delta t_safe.
    criterion : EnergyGrowth, optional
        Runaway rule and horizon; default `EnergyGrowth` with n_steps `CODE_HORIZON`.
    grid : SearchGrid
        Scan and refinement in units of ``dt_ref``.
    radius : float
        Sphere radius (m) of the code's geometry.

    Raises
    ------
    AdapterDeclined
        The code does not run assembly scenes, or not this one (one line).
    """
    crit = EnergyGrowth(n_steps=CODE_HORIZON) if criterion is None else criterion
    work = {"runs": 0, "steps": 0}
    t0 = time.perf_counter()
    # a run over the confirmation level is a confirmed runaway: the code may stop there
    stop = crit.confirm_level * initial_energy(assembly_model(scene))

    def run(dt: float, steps: int):
        req = code_request(scene, dt, steps, radius, stop)
        out = adapter.assembly(req)
        work["runs"] += 1
        work["steps"] += out.x.shape[0] - 1
        e = code_energy(req, out)
        _check_complete(e, steps, stop, adapter.label, dt)
        return e

    def evaluate(need: dict) -> dict:
        rows: dict = {}
        for i, dts in need.items():
            rows[i] = []
            for dt in np.asarray(dts, dtype=float).tolist():
                verdict = judge_energy(run(dt, int(crit.n_steps)), crit)
                if verdict[3]:  # crossed, not yet decided: the confirmation horizon
                    verdict = judge_energy(run(dt, int(crit.confirm_steps)), crit)
                rows[i].append((dt, *verdict[:3]))
        return rows

    search = search_steps(evaluate, [float(dt_ref)], grid)[0]
    lo, hi = search.bracket()
    return CodeSearch(
        dt_crit=float(hi),
        dt_stable=float(lo),
        evidence=search.evidence.get(hi),
        runs=work["runs"],
        steps=work["steps"],
        wall_s=time.perf_counter() - t0,
    )


# A run may end early only past the stop energy: the code judges its own kinetic energy,
# the suite the energy of the samples it printed (15 digits; a leapfrog's half-step
# velocities), and a runaway grows by orders of magnitude a step: 1e-3 below still counts.
_STOP_RTOL = 1e-3


def _check_complete(e: np.ndarray, steps: int, stop: float, who: str, dt: float) -> None:
    """Refuse (`AdapterOutputError`, one line) a run that ended before ``steps`` steps
    below ``stop`` with a finite energy: judged on the steps it ran, a code that quietly
    gave up would read as stable (`reference_impl.adapters._cmd_assembly`'s rule)."""
    done = len(e) - 1
    if done >= steps or not math.isfinite(e[-1]) or e[-1] >= (1.0 - _STOP_RTOL) * stop:
        return
    raise AdapterOutputError(
        f"{who}: the run at dt = {dt:.6g} s ended after {done} of {steps} steps with energy "
        f"{e[-1]:.6g} J, not past the stop energy {stop:.6g} J; a code records every step "
        "unless its run is past the stop energy or not finite"
    )


def suite_dt_crit(scene, dt_ref: float, criterion: EnergyGrowth, grid: SearchGrid) -> float:
    """The suite's own Delta t_crit (s) of the scene's unperturbed lane, same rule and grid."""
    ens = search_ensemble(assembly_model(scene), dt_ref, n_lanes=1, criterion=criterion,
                          grid=grid)  # fmt: skip
    return float(ens.dt_crit[0])


@dataclass(frozen=True)
class AdviceRow:
    """One row of `assembly_codes_table` (SI units; inf / NaN where there is no value).

    Attributes
    ----------
    code, scene : str
        Registry name of the code; the chain scene.
    n_bodies : int
        N.
    coordination : float
        Z (walls counted).
    advice : str
        The advice's name ("rayleigh", "hertz", "PWaveTimeStep",
        "GlobalStiffnessTimeStepper", or "none").
    advice_dt : float
        The advised step (s); NaN for none.
    dt_crit : float
        The code's measured Delta t_crit (s) (`code_dt_crit`); NaN where it declines.
    dt_crit_suite : float
        The suite's own Delta t_crit of the same scene, horizon, rule and grid (s).
    dt_safe : float
        The paper's Delta t_safe (s) of the scene (the striker's mass and speed).
    factor : float
        dt_crit / advice_dt: above 1 the advice is safe by that factor.
    safe : bool or None
        advice_dt <= dt_crit; None where either is missing.
    note : str
        Why a value is missing (not installed, declined, no advice); "" otherwise.
    """

    code: str
    scene: str
    n_bodies: int
    coordination: float
    advice: str
    advice_dt: float
    dt_crit: float
    dt_crit_suite: float
    dt_safe: float
    factor: float
    safe: bool | None
    note: str = ""

    def to_dict(self) -> dict:
        """JSON-safe fields (non-finite numbers as None)."""
        return {k: (None if isinstance(v, float) and not math.isfinite(v) else v)
                for k, v in asdict(self).items()}  # fmt: skip


def _rows_for(code: str, adapter, scene, horizon: int, radius: float, suite: float,
              safe: float) -> list[AdviceRow]:  # fmt: skip
    """The rows of one code on one chain (one per advice the code gives)."""
    base = {"code": code, "scene": scene.name, "n_bodies": scene.assembly.n_bodies,
            "coordination": assembly_model(scene).assembly.coordination,
            "dt_crit_suite": suite, "dt_safe": safe}  # fmt: skip
    crit = EnergyGrowth(n_steps=int(horizon))
    try:
        found = code_dt_crit(adapter, scene, safe, criterion=crit, radius=radius)
        # the advice of the start (LIGGGHTS reads its Hertz time from the speeds after its
        # one step): a step of ADVICE_DT Delta t_safe leaves the start unchanged to 1e-3
        advice = adapter.step_advice(code_request(scene, ADVICE_DT * safe, int(horizon), radius))
    except AdapterDeclined as exc:
        note = "; ".join([exc.declined] + ([NO_ADVICE[code]] if code in NO_ADVICE else []))
        return [AdviceRow(**base, advice="none", advice_dt=math.nan, dt_crit=math.nan,
                          factor=math.nan, safe=None, note=note)]  # fmt: skip
    except AdapterError as exc:  # the code failed (error, bad output, crash): its row says so
        note = f"{code} failed: {' '.join(str(exc).split())}"
        return [AdviceRow(**base, advice="none", advice_dt=math.nan, dt_crit=math.nan,
                          factor=math.nan, safe=None, note=note)]  # fmt: skip
    if not advice:
        note = NO_ADVICE.get(code, f"{code} gives no step advice")
        return [AdviceRow(**base, advice="none", advice_dt=math.nan, dt_crit=found.dt_crit,
                          factor=math.nan, safe=None, note=note)]  # fmt: skip
    out = []
    for name, dt in advice.items():
        out.append(
            AdviceRow(
                **base,
                advice=name,
                advice_dt=float(dt),
                dt_crit=found.dt_crit,
                factor=found.dt_crit / float(dt),
                safe=bool(dt <= found.dt_crit),
            )
        )
    return out


def assembly_codes_table(
    codes=CODES, sizes=SIZES, *, horizon: int = CODE_HORIZON, radius: float = RADIUS,
    base: str = "chain-hertz", lattices: bool = False,
) -> list[AdviceRow]:  # fmt: skip
    """Issue 39 section 4: each code's measured Delta t_crit and its advice, per scene.

    For each code (registry names or specs; a code that is not installed, that does not
    run assembly scenes, or that fails on a scene (an error, malformed output, a crash:
    an isolated code runs in a bench worker process, `open_code`) gives one row per size
    saying so) and each N in ``sizes``: the
    ``base`` chain with N bodies, the code's Delta t_crit by `code_dt_crit` at
    ``horizon`` steps, the suite's own Delta t_crit of the same search, the paper's
    Delta t_safe, and one row per advice the code computes (`AdviceRow`: code, scene, N,
    Z, advice name, advice dt, measured dt_crit, factor, safe). Seconds per code and
    size (LIGGGHTS ~1 s, YADE ~3 s with its start-up). With ``lattices``, the same for
    each periodic lattice of `LATTICE_SIZES` after the chains (`lattice_scene`: the
    ``lattice-hertz-triangular`` scene's spheres, law and striker; ~15 s per code and
    lattice); the default keeps the chains alone (the report's rows).

    Parameters
    ----------
    codes : sequence of str
        Registry names (default `CODES`: every built-in code that runs chains).
    sizes : sequence of int
        Numbers of bodies N (>= 1).
    horizon : int
        Steps of each run (the criterion's n_steps).
    radius : float
        Sphere radius (m).
    base : str
        The chain scene resized to each N (default ``chain-hertz``).
    lattices : bool
        Also the lattices of `LATTICE_SIZES` (default False: chains only).
    """
    crit = EnergyGrowth(n_steps=int(horizon))
    scenes = [chain_scene(n, base) for n in sizes]
    if lattices:
        scenes += [lattice_scene(name, cells) for name, cells in LATTICE_SIZES]
    refs = []
    for sc in scenes:
        model = assembly_model(sc)
        safe = dt_safe_conventions(model, initial_energy(model))["paper"]
        refs.append((safe, suite_dt_crit(sc, safe, crit, CODE_GRID)))
    rows: list[AdviceRow] = []
    for code in codes:
        try:  # in a bench worker process where the code asks for isolation (`open_code`)
            adapter = open_code(code)
        except HCVInputError as exc:  # not installed: the registry's one line
            for sc, (safe, suite) in zip(scenes, refs, strict=True):
                rows.append(AdviceRow(
                    code=code, scene=sc.name, n_bodies=sc.assembly.n_bodies,
                    coordination=assembly_model(sc).assembly.coordination, advice="none",
                    advice_dt=math.nan, dt_crit=math.nan, dt_crit_suite=suite, dt_safe=safe,
                    factor=math.nan, safe=None, note=str(exc)))  # fmt: skip
            continue
        try:
            for sc, (safe, suite) in zip(scenes, refs, strict=True):
                rows += _rows_for(code, adapter, sc, horizon, radius, suite, safe)
        finally:
            adapter.close()
    return rows


def code_report(adapter: ContactAdapter, scene, horizon: int = CODE_HORIZON,
                radius: float = RADIUS) -> dict:  # fmt: skip
    """``hcv dt-crit SCENE --adapter CODE``: one code on one chain scene (JSON-safe, SI units).

    Fields: ``code``, ``scene``, ``n_bodies``, ``horizon``, ``dt_safe`` (paper), the code's
    ``dt_crit`` and ``dt_stable`` with ``evidence``, ``runs`` and ``wall_s`` of its search,
    the suite's ``dt_crit_suite`` (same horizon, rule and grid), ``criterion``, and
    ``advice``: one entry per advice the code computes (name, dt, factor dt_crit / dt,
    safe), empty with ``advice_note`` where it computes none.

    Raises
    ------
    AdapterDeclined
        The code does not run assembly scenes, or not this one.
    """
    crit = EnergyGrowth(n_steps=int(horizon))
    model = assembly_model(scene)
    safe = dt_safe_conventions(model, initial_energy(model))["paper"]
    found = code_dt_crit(adapter, scene, safe, criterion=crit, radius=radius)
    advice = adapter.step_advice(code_request(scene, ADVICE_DT * safe, int(horizon), radius))
    out = {
        "code": adapter.label,
        "scene": scene.name,
        "n_bodies": model.assembly.n_bodies,
        "coordination": model.assembly.coordination,
        "horizon": int(horizon),
        "dt_safe": safe,
        "dt_crit": found.dt_crit,
        "dt_stable": found.dt_stable,
        "evidence": found.evidence,
        "runs": found.runs,
        "wall_s": found.wall_s,
        "dt_crit_suite": suite_dt_crit(scene, safe, crit, CODE_GRID),
        "criterion": crit.describe(),
        "advice": [
            {
                "name": k,
                "dt": float(v),
                "factor": found.dt_crit / float(v),
                "safe": bool(v <= found.dt_crit),
            }
            for k, v in advice.items()
        ],  # fmt: skip
    }
    if not advice:
        out["advice_note"] = NO_ADVICE.get(adapter.name, f"{adapter.label} gives no step advice")
    return out
