"""Measured critical time step of velocity Verlet for a nonlinear contact (section 6).

Section 6 claims that Delta t_safe = 2 sqrt(m) / max_[0, q_max] U'/sqrt(2U) is a
lower bound of the critical step: every Delta t <= Delta t_safe is stable. This
module measures the critical step Delta t_crit with the lane engine of
`reference_impl.integrators.verlet` and compares; it never assumes the claim.

Scenes (names exactly as the scene files spell them)
----------------------------------------------------
"two-sided"  the particle oscillates through the contact, U(|q|), starting at
             q = 0 with speed v0 (E_0 = m v0^2 / 2);
"two-walls"  one-sided contacts at both ends of a free-flight gap, starting at
             the onset of one contact with speed v0 (repeated impacts);
"impact"     one collision against one wall, from contact onset to separation.

What "unstable" means is a named criterion: `EnergyGrowth` for the sustained
scenes (E_n > factor * E_0 for some n <= n_steps), `ImpactGain` for the single
impact (rebound energy > (1 + tol) E_0, i.e. a passive collision gains energy,
checked with the onset exactly at a step boundary and at stratified onset
phases inside a step). A lane that leaves the potential's domain or becomes
non-finite is unstable under both.

Search: stability need not be monotone in Delta t, so a grid is scanned first
and the smallest failing step is then bracketed by repeated k-section (k
interior points per round, all run as lanes of one engine call) until the
bracket is narrower than the resolution (default 0.1 % of Delta t_safe).
Delta t_crit is the smallest failing step found. Failures narrower than the
scan step below the first failing grid point can be missed; in chaotic regimes
(e.g. q^2/(1+q^2) at high speed) the outcome of a lane can change with the
last bits of Delta t, so Delta t_crit there is known only to that extent.

Beyond the paper, `reference_impl.dtcrit_map.recommended_step` gives a step
that the same searches found safe on every case measured.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
from scipy.optimize import minimize_scalar

from .errors import HCVInputError
from .integrators.verlet import (
    SCENE_IMPACT,
    SCENE_WALLS,
    STATUS_NAMES,
    LaneBatch,
    run_lanes,
)
from .potentials.base import Potential
from .stability import dt_safe as _dt_safe

__all__ = [
    "KINDS",
    "EnergyGrowth",
    "ImpactGain",
    "Criterion",
    "SearchGrid",
    "DtCritResult",
    "default_criterion",
    "parse_criterion",
    "tangent_step",
    "search_scene",
]

KINDS = ("impact", "two-sided", "two-walls")

# Without a gap in the scene, two-walls uses gap = this many q_max: a flight of
# a few contact durations, so that N steps contain thousands of impacts.
_DEFAULT_GAP_QMAX = 5.0
# A single-impact lane stops (as no-separation) after this many times the
# straight-line time q_max / v0: an elastic power-law contact U ~ q^n lasts
# 2 q_max / v0 * int_0^1 ds / sqrt(1 - s^n) <= 4 q_max / v0 for n >= 1, so the
# budget leaves a factor 10 for other shapes; damped lanes may hit it.
_IMPACT_TIME_BUDGET = 40.0
# Extra steps for an impact lane, so that even dt >> contact time can separate.
_IMPACT_MIN_STEPS = 64
# In-contact energy guard of an impact lane (multiples of E_0): only stops
# runaway arithmetic; the verdict uses the rebound energy.
_IMPACT_GUARD = 1e12


@dataclass(frozen=True)
class EnergyGrowth:
    """Sustained-scene criterion: unstable when E_n > factor * E_0 for some n <= n_steps.

    Attributes
    ----------
    factor : float
        Energy growth factor (> 1), default 100.
    n_steps : int
        Step budget N (>= 1), default 1e5.
    """

    factor: float = 100.0
    n_steps: int = 100_000

    def __post_init__(self):
        if not (math.isfinite(self.factor) and self.factor > 1):
            raise HCVInputError(f"EnergyGrowth factor must be finite and > 1, got {self.factor!r}")
        if int(self.n_steps) != self.n_steps or self.n_steps < 1:
            raise HCVInputError(
                f"EnergyGrowth n_steps must be an integer >= 1, got {self.n_steps!r}")

    def describe(self) -> str:
        """One line saying what counts as unstable."""
        return f"energy-growth: E_n > {self.factor:g} E_0 for some n <= {int(self.n_steps)}"


@dataclass(frozen=True)
class ImpactGain:
    """Single-impact criterion: unstable when the rebound energy exceeds (1 + tol) E_0.

    Attributes
    ----------
    tol : float
        Allowed relative energy gain of a passive collision (>= 0), default 0.01.
    n_phases : int
        Number of onset phases phi = (j + 1/2) / n_phases inside a step (the
        contact starts a fraction phi of a step after a step boundary), tried
        in addition to phi = 0; default 16. 0 tries the step boundary only.
    """

    tol: float = 0.01
    n_phases: int = 16

    def __post_init__(self):
        if not (math.isfinite(self.tol) and self.tol >= 0):
            raise HCVInputError(f"ImpactGain tol must be finite and >= 0, got {self.tol!r}")
        if int(self.n_phases) != self.n_phases or self.n_phases < 0:
            raise HCVInputError(
                f"ImpactGain n_phases must be an integer >= 0, got {self.n_phases!r}")

    def describe(self) -> str:
        """One line saying what counts as unstable."""
        return (f"impact-gain: rebound energy > (1 + {self.tol:g}) E_0 at onset phase 0 or any of "
                f"{int(self.n_phases)} phases in a step")

    def phases(self) -> np.ndarray:
        """Onset phases (fractions of a step): 0, then the stratified ones."""
        j = np.arange(int(self.n_phases))
        return np.concatenate([[0.0], (j + 0.5) / max(int(self.n_phases), 1)])


Criterion = EnergyGrowth | ImpactGain


def default_criterion(kind: str) -> Criterion:
    """The issue's default criterion for a scene kind."""
    _check_kind(kind)
    return ImpactGain() if kind == "impact" else EnergyGrowth()


def parse_criterion(text: str, kind: str) -> Criterion:
    """Criterion from ``"key=value,key=value"`` text (for the CLI ``--criterion``).

    Keys: ``factor``, ``n_steps`` (sustained scenes); ``tol``, ``n_phases`` (impact).
    Unknown keys or values raise `HCVInputError` with one line.
    """
    base = default_criterion(kind)
    if kind == "impact":
        fields = {"tol": float, "n_phases": int}
    else:
        fields = {"factor": float, "n_steps": int}
    kw: dict[str, Any] = {}
    for part in filter(None, (s.strip() for s in text.split(","))):
        key, sep, val = part.partition("=")
        key = key.strip()
        if not sep or key not in fields:
            raise HCVInputError(
                f"criterion for {kind!r} takes {', '.join(fields)} as key=value, got {part!r}")
        try:
            num = float(val)
            kw[key] = int(num) if fields[key] is int and num == int(num) else fields[key](num)
        except (ValueError, OverflowError):
            raise HCVInputError(f"criterion value {key}={val!r} is not a number") from None
    return type(base)(**{**asdict(base), **kw})


@dataclass(frozen=True)
class SearchGrid:
    """Grid scan and refinement of the search, in units of the reference step.

    The reference step is Delta t_safe, or `tangent_step` when Delta t_safe = 0.

    Attributes
    ----------
    lo, hi, step : float
        Uniform scan lo, lo + step, ..., hi (plus exactly 1, i.e. Delta t_safe).
    resolution : float
        Final bracket width; the issue asks for 0.1 % of Delta t_safe.
    refine_points : int
        Interior points per refinement round.
    hi_max : float
        Upward extension limit when no scanned step fails (geometric, x1.25).
    lo_min : float
        Downward extension limit when the smallest scanned step fails (x0.5).
    """

    lo: float = 0.02
    hi: float = 3.0
    step: float = 0.01
    resolution: float = 1e-3
    refine_points: int = 16
    hi_max: float = 100.0
    lo_min: float = 1e-4

    def scan(self) -> np.ndarray:
        n = int(round((self.hi - self.lo) / self.step)) + 1
        return np.unique(np.concatenate([self.lo + self.step * np.arange(n), [1.0]]))


@dataclass
class DtCritResult:
    """Outcome of one critical-step search (one speed, one scene kind).

    Attributes
    ----------
    v0 : float
        Impact speed (m/s).
    kind : str
        Scene kind.
    dt_safe : float
        Section 6 bound, supremum over [0, q_max] (s); 0 when the supremum is infinite.
    dt_safe_shortcut : float
        Endpoint shortcut 2 m v0 / U'(q_max) (s).
    dt_crit : float
        Smallest failing step found (s); inf when none failed up to the search limit.
    ratio : float
        dt_crit / dt_safe (inf when dt_safe = 0 or dt_crit = inf).
    criterion : str
        What counted as unstable.
    holds : bool
        True when every step <= dt_safe that was tried was stable, i.e.
        dt_crit > dt_safe; vacuously True when dt_safe = 0 (see `degenerate`).
    counterexample : dict or None
        When ``holds`` is False: the failing step and its energy history.
    dt_stable : float
        Largest stable step tried below dt_crit (s); the bracket is [dt_stable, dt_crit].
    dt_crit_onset : float or None
        Impact only: dt_crit with the onset exactly at a step boundary (phase 0).
    q_max : float
        Turning point (m).
    geometry : str
        Geometry class of section 6 on (0, q_max].
    degenerate : bool
        dt_safe = 0 (sup U'/sqrt(2U) infinite at q -> 0, e.g. p < 1): no usable step.
    dt_tangent : float
        2 sqrt(m / max_[0, q_max] U'') (s), the linearised limit at the stiffest point.
    recommended_dt : float
        The recommended step (s), `reference_impl.dtcrit_map.recommended_step`.
    lane_steps : int
        Verlet steps integrated by the whole `search_scene` call (all lanes).
    engine : str
        "numba" or "numpy".
    """

    v0: float
    kind: str
    dt_safe: float
    dt_safe_shortcut: float
    dt_crit: float
    ratio: float
    criterion: str
    holds: bool
    counterexample: dict | None
    dt_stable: float
    dt_crit_onset: float | None
    q_max: float
    geometry: str
    degenerate: bool
    dt_tangent: float
    recommended_dt: float = math.nan
    lane_steps: int = 0
    engine: str = ""
    extra: dict = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-ready dict (inf written as the string "inf")."""
        d = asdict(self)
        extra = d.pop("extra")
        d.update(extra)
        return _jsonable(d)


def _jsonable(x):
    if isinstance(x, dict):
        return {k: _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, (np.floating, float)):
        x = float(x)
        return x if math.isfinite(x) else ("inf" if x > 0 else "-inf" if x < 0 else "nan")
    if isinstance(x, np.integer):
        return int(x)
    if isinstance(x, np.bool_):
        return bool(x)
    return x


def _check_kind(kind: str) -> None:
    if kind not in KINDS:
        raise HCVInputError(f"scene kind must be one of {', '.join(KINDS)}; got {kind!r}")


def tangent_step(pot: Potential, m: float, q_max: float) -> float:
    """2 sqrt(m / max U'') over (0, q_max] (s): the linear Verlet limit at the stiffest point.

    Returns 0 when U'' is unbounded on the path (leading exponent < 2, e.g.
    power laws with p < 1).
    """
    if pot.leading_exponent < 2:
        return 0.0
    q = np.unique(q_max * np.concatenate([np.logspace(-12, 0, 200), np.linspace(0, 1, 801)]))
    q = np.minimum(q, pot.q_sup)
    with np.errstate(all="ignore"):
        k = pot._d2U(q)
    i = int(np.argmax(k))
    kmax = float(k[i])
    if not math.isfinite(kmax) or kmax <= 0:
        return 0.0
    if 0 < i < q.size - 1:  # interior maximum: refine between the grid neighbours
        res = minimize_scalar(lambda x: -float(pot._d2U(np.array([x]))[0]),
                              bounds=(q[i - 1], q[i + 1]), method="bounded")
        kmax = max(kmax, -float(res.fun))
    return 2.0 * math.sqrt(m / kmax)


# ----------------------------------------------------------------------------
# lanes of one search
# ----------------------------------------------------------------------------
@dataclass
class _Search:
    """State of one bracket search: one speed, one scene, one set of onset phases."""

    v0: float
    dt_ref: float
    phases: np.ndarray  # impact onset phases (fractions of a step); [0] for sustained scenes
    tried: dict = field(default_factory=dict)  # dt -> failed (bool)
    upward: float = 0.0  # largest ratio tried by the upward extension
    downward: float = math.inf  # smallest ratio tried by the downward extension
    done: bool = False

    def bracket(self) -> tuple[float, float]:
        """(largest stable dt below the smallest failure, smallest failing dt)."""
        fails = [d for d, f in self.tried.items() if f]
        f = min(fails) if fails else math.inf
        stable = [d for d, ok in self.tried.items() if not ok and d < f]
        return (max(stable) if stable else 0.0), f


def _next_dts(s: _Search, grid: SearchGrid) -> np.ndarray:
    """Steps (s) the search needs next; empty when it is finished."""
    lo, f = s.bracket()
    ref = s.dt_ref
    if not s.tried:
        return grid.scan() * ref
    if math.isinf(f):
        top = max(s.tried) / ref
        if top >= grid.hi_max:
            return np.empty(0)
        return ref * top * 1.25 ** np.arange(1, 9)
    if lo == 0.0:
        bottom = min(s.tried) / ref
        if bottom <= grid.lo_min:
            return np.empty(0)
        return ref * np.maximum(bottom * 0.5 ** np.arange(1, 9), grid.lo_min * 0.999)
    if f - lo <= grid.resolution * ref:
        return np.empty(0)
    return lo + (f - lo) * np.arange(1, grid.refine_points + 1) / (grid.refine_points + 1)


def _impact_batch(pot, m, v0, dts, phases, q_max, tol, group):
    """Impact lanes: for each dt, each onset phase phi starts at y0 = -phi v0 dt."""
    dt = np.repeat(dts, phases.size)
    phi = np.tile(phases, dts.size)
    E0 = 0.5 * m * v0 * v0
    steps = np.ceil(_IMPACT_TIME_BUDGET * q_max / (v0 * dt)).astype(np.int64) + _IMPACT_MIN_STEPS
    return dict(dt=dt, y0=-phi * v0 * dt, v0=v0, gap=0.0, e_limit=_IMPACT_GUARD * E0,
                e_final=(1.0 + tol) * E0, max_steps=steps, group=group), phi


def _sustained_batch(m, v0, dts, gap, crit, group):
    """Two-sided / two-walls lanes: start at the onset of the contact at y = gap."""
    E0 = 0.5 * m * v0 * v0
    return dict(dt=dts, y0=gap, v0=v0, gap=gap, e_limit=crit.factor * E0, e_final=np.inf,
                max_steps=int(crit.n_steps), group=group)


def _build(searches, need, kind, pot, m, q_maxes, gap_of, crit):
    """One LaneBatch for every search that still needs steps; lane -> search map."""
    parts, owners, phis = [], [], []
    for i, dts in need.items():
        s = searches[i]
        if kind == "impact":
            b, phi = _impact_batch(pot, m, s.v0, dts, s.phases, q_maxes[i], crit.tol, i)
        else:
            b = _sustained_batch(m, s.v0, dts, gap_of[i], crit, i)
            phi = np.zeros(dts.size)
        n = np.asarray(b["dt"]).size
        parts.append({k: np.broadcast_to(v, (n,)) for k, v in b.items()})
        owners.append(np.full(n, i))
        phis.append(phi)
    batch = LaneBatch(**{k: np.concatenate([p[k] for p in parts]) for k in parts[0]})
    return batch, np.concatenate(owners), np.concatenate(phis)


def _record(searches, owners, batch, res):
    """Fold one engine call into the searches' tried steps."""
    for i in np.unique(owners):
        sel = owners == i
        dts, failed, ran = batch.dt[sel], res.failed[sel], res.ran[sel]
        for d in np.unique(dts):
            at = dts == d
            if np.any(failed[at]):
                searches[i].tried[float(d)] = True
            elif np.all(ran[at]):
                searches[i].tried.setdefault(float(d), False)


def _progress_fraction(s: _Search, grid: SearchGrid) -> float:
    """Rough completed fraction of one search, for progress bars."""
    if s.done:
        return 1.0
    if not s.tried:
        return 0.0
    lo, f = s.bracket()
    if lo == 0.0 or math.isinf(f):
        return 0.3
    width0, width = grid.step * s.dt_ref, max(f - lo, 1e-300)
    span = math.log(max(width0 / (grid.resolution * s.dt_ref), 1.0 + 1e-9))
    return 0.3 + 0.7 * min(max(math.log(max(width0 / width, 1.0)) / span, 0.0), 1.0)


def _checkpoints(n: int) -> np.ndarray:
    """Steps 1, 10, 100, ... and n: where the energy history is summarised."""
    return np.unique(np.concatenate([10 ** np.arange(int(math.log10(max(n, 1))) + 1), [n]]))


def _counterexample(pot, m, kind, s, dt, gap, crit, q_max, dt_safe, zeta, engine):
    """Re-run the failing step with an energy history; the worst onset phase for impacts."""
    if kind == "impact":
        b, phi = _impact_batch(pot, m, s.v0, np.array([dt]), s.phases, q_max, crit.tol, 0)
        n_cp = int(np.max(b["max_steps"]))
    else:
        b, phi = _sustained_batch(m, s.v0, np.array([dt]), gap, crit, 0), np.zeros(1)
        n_cp = int(crit.n_steps)
    n = np.asarray(b["dt"]).size
    batch = LaneBatch(**{k: np.broadcast_to(v, (n,)) for k, v in b.items()})
    cps = _checkpoints(n_cp)
    res = run_lanes(pot, m, SCENE_IMPACT if kind == "impact" else SCENE_WALLS, batch,
                    zeta=zeta, checkpoints=cps, engine=engine)
    E0 = 0.5 * m * s.v0 * s.v0
    key = np.where(res.failed, np.nan_to_num(res.e_end, nan=np.inf), -np.inf)
    j = int(np.argmax(key)) if np.any(res.failed) else int(np.argmax(res.e_max))
    hist = {int(c): float(res.hist[j, k]) for k, c in enumerate(cps) if np.isfinite(res.hist[j, k])}
    out = {
        "dt": float(dt),
        "dt_over_dt_safe": float(dt / dt_safe) if dt_safe > 0 else math.inf,
        "status": STATUS_NAMES[int(res.status[j])],
        "steps": int(res.steps[j]),
        "E0": E0,
        "E_max_over_E0": float(res.e_max[j] / E0),
        "E_end_over_E0": float(res.e_end[j] / E0),
        "max_E_over_E0_by_step": hist,
    }
    if kind == "impact":
        out["onset_phase"] = float(phi[j])
    return out


def _validated(potential, m, velocities, kind, gap, zeta, criterion):
    _check_kind(kind)
    if not isinstance(potential, Potential):
        raise HCVInputError(f"potential must be a Potential, got {potential!r}")
    if not (isinstance(m, (int, float)) and math.isfinite(m) and m > 0):
        raise HCVInputError(f"mass m must be a finite number > 0 (kg), got {m!r}")
    vs = [float(v) for v in (velocities if isinstance(velocities, Iterable) else [velocities])]
    if not vs or not all(math.isfinite(v) and v > 0 for v in vs):
        raise HCVInputError(f"velocities must be finite numbers > 0 (m/s), got {velocities!r}")
    if gap is not None and not (math.isfinite(gap) and gap >= 0):
        raise HCVInputError(f"gap must be a finite number >= 0 (m), got {gap!r}")
    z = 0.0 if zeta is None else float(zeta)
    if not (math.isfinite(z) and z >= 0):
        raise HCVInputError(f"damping ratio zeta must be finite and >= 0, got {zeta!r}")
    crit = default_criterion(kind) if criterion is None else criterion
    want = ImpactGain if kind == "impact" else EnergyGrowth
    if not isinstance(crit, want):
        raise HCVInputError(f"scene kind {kind!r} needs a {want.__name__} criterion, got {crit!r}")
    return vs, z, crit


def search_scene(potential: Potential, m: float, velocities: Sequence[float] | float, kind: str, *,
                 gap: float | None = None, zeta: float | None = None,
                 criterion: Criterion | None = None, grid: SearchGrid = SearchGrid(),
                 progress: Callable[[float, float], None] | None = None,
                 engine: str = "auto",
                 recommend: Callable | None | str = "default") -> list[DtCritResult]:
    """Measure Delta t_crit of velocity Verlet for each impact speed of one scene.

    Parameters
    ----------
    potential : Potential
        Contact potential U(q).
    m : float
        Particle mass (kg).
    velocities : float or sequence of float
        Impact speeds v0 (m/s, > 0); E_0 = m v0^2 / 2.
    kind : {"impact", "two-sided", "two-walls"}
        Scene kind (see the module docstring).
    gap : float, optional
        Free-flight gap of "two-walls" (m); default 5 q_max of each speed.
    zeta : float, optional
        Damping ratio of the universal law C = 2 zeta sqrt(m) U'/sqrt(2U); default 0.
    criterion : EnergyGrowth or ImpactGain, optional
        What counts as unstable; default `default_criterion(kind)`.
    grid : SearchGrid
        Scan and refinement settings.
    progress : callable, optional
        Called as ``progress(completed, total)`` (floats, total = number of
        searches) after every engine call, for a progress bar.
    engine : {"auto", "numba", "numpy"}
        Lane engine (auto: numba for known families).
    recommend : callable, None or "default"
        ``recommend(potential, m, v0, kind) -> float`` filling ``recommended_dt``;
        "default" is `reference_impl.dtcrit_map.recommended_step`, None leaves NaN.

    Returns
    -------
    list of DtCritResult
        One per speed, in the given order.
    """
    vs, z, crit = _validated(potential, m, velocities, kind, gap, zeta, criterion)
    if isinstance(recommend, str):
        from .dtcrit_map import recommended_step as recommend  # the map module imports this one
    info, searches, main_of = [], [], []
    for v0 in vs:
        ss = _dt_safe(potential, m, v0)
        q_max = potential.turning_point(0.5 * m * v0 * v0, check=False)
        dt_tan = tangent_step(potential, m, q_max)
        ref = ss.dt_safe if ss.dt_safe > 0 else (dt_tan if dt_tan > 0 else ss.dt_shortcut)
        g = 0.0 if kind != "two-walls" else (_DEFAULT_GAP_QMAX * q_max if gap is None else gap)
        info.append((ss, q_max, dt_tan, g))
        main_of.append(len(searches))
        if kind == "impact":
            searches.append(_Search(v0, ref, crit.phases()))
            searches.append(_Search(v0, ref, np.zeros(1)))
        else:
            searches.append(_Search(v0, ref, np.zeros(1)))
    owner_info = [info[j] for j, v0 in enumerate(vs) for _ in range(2 if kind == "impact" else 1)]
    scene = SCENE_IMPACT if kind == "impact" else SCENE_WALLS
    lane_steps, used = 0, ""
    if progress is not None:
        progress(0.0, float(len(searches)))
    for _ in range(200):  # rounds; a search needs ~4, the cap only guards against a bug
        need = {}
        for i, s in enumerate(searches):
            if not s.done:
                d = _next_dts(s, grid)
                if d.size:
                    need[i] = d
                else:
                    s.done = True
        if not need:
            break
        batch, owners, _ = _build(searches, need, kind, potential, m,
                                  [o[1] for o in owner_info], [o[3] for o in owner_info], crit)
        res = run_lanes(potential, m, scene, batch, zeta=z, skip_after_fail=True, engine=engine)
        lane_steps += int(res.steps.sum())
        used = res.engine
        _record(searches, owners, batch, res)
        if progress is not None:
            progress(sum(_progress_fraction(s, grid) for s in searches), float(len(searches)))
    out = []
    for j, v0 in enumerate(vs):
        ss, q_max, dt_tan, g = info[j]
        s = searches[main_of[j]]
        lo, f = s.bracket()
        holds = bool(f > ss.dt_safe)
        ce = None
        if not holds:
            ce = _counterexample(potential, m, kind, s, f, g, crit, q_max, ss.dt_safe, z, engine)
        onset = searches[main_of[j] + 1].bracket()[1] if kind == "impact" else None
        ratio = f / ss.dt_safe if ss.dt_safe > 0 else math.inf
        extra = {"gap": g} if kind == "two-walls" else {}
        if z > 0:
            extra["zeta"] = z
        out.append(DtCritResult(
            v0=v0, kind=kind, dt_safe=ss.dt_safe, dt_safe_shortcut=ss.dt_shortcut, dt_crit=f,
            ratio=ratio, criterion=crit.describe(), holds=holds, counterexample=ce, dt_stable=lo,
            dt_crit_onset=onset, q_max=q_max, geometry=ss.geometry, degenerate=ss.dt_safe == 0,
            dt_tangent=dt_tan,
            recommended_dt=math.nan if recommend is None else recommend(potential, m, v0, kind),
            lane_steps=lane_steps, engine=used, extra=extra))
    if progress is not None:
        progress(float(len(searches)), float(len(searches)))
    return out
