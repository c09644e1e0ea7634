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

What fails is a named criterion, and each failure has a kind (``failure_kind``):

"runaway"   sustained scenes, `EnergyGrowth`: E_n > factor E_0 for some
            n <= n_steps, *confirmed* by the same lane going on to exceed
            factor * confirm_factor E_0 within confirm_horizon * n_steps steps
            (defaults 100 E_0 in 1e5 steps, confirmed at 1e6 E_0 within 1e6
            steps), or leaving the potential's domain (q > q_sup: the body
            passed through the wall) or becoming non-finite. Only this is an
            instability: ``holds`` is False only for a runaway strictly below
            Delta t_safe. Where the growth is slow (q^2/(1+q^2), the linear
            spring between two walls) the confirmed step moves with
            confirm_horizon; the counterexample's ``steps`` / n_steps is the
            horizon that step needed (the section 6 claim reports it).
"bounded"   sustained scenes: the lane crossed factor E_0 but stayed below the
            confirmation level to the end of the longer horizon: a large but
            saturating excursion (e.g. the linear spring just below 2/omega,
            whose orbit peaks at E_0 / (1 - (omega dt / 2)^2)). Not an
            instability; reported as ``dt_bounded`` and its peak, and the search
            for a runaway goes on above it.
"accuracy"  single impact, `ImpactGain`: rebound energy > (1 + tol) E_0 (a
            passive collision gains energy), checked with the onset exactly at a
            step boundary and at stratified onset phases inside a step. It moves
            with tol, so it is an accuracy threshold: reported as
            ``dt_accuracy`` (the largest step below the first failure whose
            rebound gain stays within tol) beside Delta t_safe, never counted as
            an instability.
None        no failure in the search range.

Every user-controlled size has a stated upper bound checked before any work
(`MAX_N_STEPS`, `MAX_CONFIRM_STEPS`, `MAX_FACTOR`, `MAX_N_PHASES`, `MAX_SPEEDS`,
`MAX_SCAN_POINTS`, `MAX_REFINE_POINTS`), and the lanes of one round are run in
chunks of at most `MAX_LANES_PER_CALL`, so memory does not grow with n_phases.

Search: stability need not be monotone in Delta t, so a grid is scanned first
and the smallest failing step is then bracketed by repeated k-section (k
interior points per round, all run as lanes of one engine call) until the
bracket is narrower than the resolution (default 0.1 % of Delta t_safe).
Delta t_crit is the smallest failing step found. Failures narrower than the
scan step below the first failing grid point can be missed; in chaotic regimes
(e.g. q^2/(1+q^2) at high speed) the outcome of a lane can change with the
last bits of Delta t, so Delta t_crit there is known only to that extent.

Beyond the paper, `reference_impl.stability.recommend.recommended_step` gives a step
that the same searches found safe on every case measured.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from reference_impl.errors import HCVInputError, UnsupportedError
from reference_impl.integrators.verlet import (
    SCENE_IMPACT,
    SCENE_WALLS,
    STATUS_NAMES,
    LaneBatch,
    run_lanes,
)
from reference_impl.potentials.base import Potential
from reference_impl.stability.bound import dt_safe as _dt_safe
from reference_impl.stability.criteria import (
    FAILURE_KINDS,
    KINDS,
    MAX_CONFIRM_STEPS,
    MAX_FACTOR,
    MAX_LANES_PER_CALL,
    MAX_N_PHASES,
    MAX_N_STEPS,
    MAX_REFINE_POINTS,
    MAX_SCAN_POINTS,
    MAX_SPEEDS,
    MAX_TOL,
    Criterion,
    EnergyGrowth,
    ImpactGain,
    SearchGrid,
    _validated,
    default_criterion,
    parse_criterion,
)
from reference_impl.stability.recommend import tangent_step
from reference_impl.stability.result import DtCritResult

__all__ = [
    "KINDS",
    "FAILURE_KINDS",
    "MAX_N_STEPS",
    "MAX_CONFIRM_STEPS",
    "MAX_FACTOR",
    "MAX_TOL",
    "MAX_N_PHASES",
    "MAX_SPEEDS",
    "MAX_SCAN_POINTS",
    "MAX_REFINE_POINTS",
    "MAX_LANES_PER_CALL",
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

# The default scan and refinement (frozen, so one instance serves every call).
_DEFAULT_GRID = SearchGrid()
# Without a gap in the scene, two-walls uses gap = this many q_max: a flight of
# a few contact durations, so that N steps contain thousands of impacts.
_DEFAULT_GAP_QMAX = 5.0
# A two-walls lane's positions lie near the gap, so its overlap is resolved to
# ulp(gap): refused when that exceeds this fraction of q_max (the energy then
# carries ~n ulp(gap) / q_max of noise per contact, which must stay far below
# every criterion's threshold; a gap of 1e14 m left the overlap below one ulp and
# no failure was ever seen, issue 22).
_GAP_ULP_RTOL = 1e-8
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
    bounded: dict = field(default_factory=dict)  # dt -> peak E / E_0 of a bounded excursion
    evidence: dict = field(default_factory=dict)  # failing dt -> "confirmed" or "domain"
    done: bool = False

    def smallest_bounded(self) -> tuple[float, float]:
        """(smallest dt with a bounded excursion below the first failure, its peak E / E_0)."""
        f = self.bracket()[1]
        b = [d for d in self.bounded if d < f]
        return (min(b), self.bounded[min(b)]) if b else (math.inf, math.nan)

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
    return dict(
        dt=dt,
        y0=-phi * v0 * dt,
        v0=v0,
        gap=0.0,
        e_limit=_IMPACT_GUARD * E0,
        e_final=(1.0 + tol) * E0,
        max_steps=steps,
        group=group,
    ), phi


def _sustained_batch(m, v0, dts, gap, crit, group):
    """Two-sided / two-walls lanes: start at the onset of the contact at y = gap.

    A lane crossing factor E_0 is followed on to the confirmation level.
    """
    E0 = 0.5 * m * v0 * v0
    return dict(
        dt=dts,
        y0=gap,
        v0=v0,
        gap=gap,
        e_limit=crit.factor * E0,
        e_final=np.inf,
        max_steps=int(crit.n_steps),
        group=group,
        e_confirm=crit.confirm_level * E0,
        confirm_steps=crit.confirm_steps,
    )


def _build(searches, need, kind, pot, m, q_maxes, gap_of, crit):
    """One LaneBatch for ``need`` = {search: (dts, phases)}; lane -> search map."""
    parts, owners, phis = [], [], []
    for i, (dts, phases) in need.items():
        s = searches[i]
        if kind == "impact":
            b, phi = _impact_batch(pot, m, s.v0, dts, phases, q_maxes[i], crit.tol, i)
        else:
            b = _sustained_batch(m, s.v0, dts, gap_of[i], crit, i)
            phi = np.zeros(dts.size)
        n = np.asarray(b["dt"]).size
        parts.append({k: np.broadcast_to(v, (n,)) for k, v in b.items()})
        owners.append(np.full(n, i))
        phis.append(phi)
    batch = LaneBatch(**{k: np.concatenate([p[k] for p in parts]) for k in parts[0]})
    return batch, np.concatenate(owners), np.concatenate(phis)


def _record(searches, owners, batch, res, m):
    """Fold one engine call into the searches' tried steps (and bounded excursions)."""
    for i in np.unique(owners):
        sel = owners == i
        dts, failed, ran = batch.dt[sel], res.failed[sel], res.ran[sel]
        bounded, st = res.bounded[sel], res.status[sel]
        peak = res.e_max[sel] / (0.5 * m * batch.v0[sel] ** 2)  # lanes start out of contact
        s = searches[i]
        for d in np.unique(dts):
            at = dts == d
            key = float(d)
            if np.any(failed[at]):
                s.tried[key] = True
                blown = np.any(st[at] == STATUS_NAMES.index("blown"))
                s.evidence[key] = "domain" if blown else "confirmed"
            elif np.all(ran[at]):
                s.tried.setdefault(key, False)
                if np.any(bounded[at]):
                    s.bounded[key] = float(np.max(peak[at & bounded]))


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
        n_cp = crit.confirm_steps
    n = np.asarray(b["dt"]).size
    batch = LaneBatch(**{k: np.broadcast_to(v, (n,)) for k, v in b.items()})
    cps = _checkpoints(n_cp)
    res = run_lanes(
        pot,
        m,
        SCENE_IMPACT if kind == "impact" else SCENE_WALLS,
        batch,
        zeta=zeta,
        checkpoints=cps,
        engine=engine,
    )
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
    else:
        out["evidence"] = "domain" if out["status"] == "blown" else "confirmed"
    return out


def _chunks(searches, need, max_lanes):
    """Split one round's {search: dts} into parts {search: (dts, phases)} of <= max_lanes lanes.

    Phases of an impact search are split when dts x phases exceeds max_lanes,
    and a later part drops the steps at or above a failure found by an earlier
    one, so memory is bounded whatever n_phases is.
    """
    part, count = {}, 0
    for i, dts in need.items():
        phases = searches[i].phases
        per = max(1, max_lanes // max(dts.size, 1))  # phases per part
        for p0 in range(0, phases.size, per):
            f = searches[i].bracket()[1]
            keep = dts[(dts < f) & ~np.isin(dts, [d for d, x in searches[i].tried.items() if x])]
            if keep.size == 0:
                break
            ph = phases[p0 : p0 + per]
            if count and count + keep.size * ph.size > max_lanes:
                yield part
                part, count = {}, 0
            if i in part:  # the same search in one part twice: flush first
                yield part
                part, count = {}, 0
            part[i] = (keep, ph)
            count += keep.size * ph.size
            if p0 + per < phases.size:  # later phases need this part's outcome
                yield part
                part, count = {}, 0
    if part:
        yield part


def _result(
    pot,
    m,
    v0,
    kind,
    crit,
    ss,
    q_max,
    dt_tan,
    g,
    z,
    engine,
    s,
    onset_search,
    lo,
    f,
    recommend,
    lane_steps,
    used,
) -> DtCritResult:
    """The DtCritResult of one speed from its finished search(es)."""
    if lo == 0.0 and math.isfinite(f):
        # Every step tried failed, down to the search floor: that floor is where the
        # search stopped, not a measured critical step (issue 22).
        raise UnsupportedError(
            f"every step tried failed for v0 = {v0!r} m/s, down to the search floor dt = {f:.3g} s "
            f"({f / s.dt_ref:.3g} of the reference step {s.dt_ref:.3g} s) under the criterion "
            f"'{crit.describe()}': no critical step was measured; loosen the criterion"
        )
    ratio = f / ss.dt_safe if ss.dt_safe > 0 else math.inf
    extra = {"gap": g} if kind == "two-walls" else {}
    if z > 0:
        extra["zeta"] = z
    dt_b, peak_b = (math.inf, math.nan) if kind == "impact" else s.smallest_bounded()
    if kind == "impact":
        fk = "accuracy" if math.isfinite(f) else None
    else:
        fk = "runaway" if math.isfinite(f) else ("bounded" if math.isfinite(dt_b) else None)
    holds = not (fk == "runaway" and f < ss.dt_safe)
    ce = None
    if math.isfinite(f) and f < ss.dt_safe:
        ce = _counterexample(pot, m, kind, s, f, g, crit, q_max, ss.dt_safe, z, engine)
    acc = lo if kind == "impact" else None
    return DtCritResult(
        v0=v0,
        kind=kind,
        dt_safe=ss.dt_safe,
        dt_safe_shortcut=ss.dt_shortcut,
        dt_crit=f,
        ratio=ratio,
        criterion=crit.describe(),
        holds=holds,
        counterexample=ce,
        dt_stable=lo,
        dt_crit_onset=onset_search.bracket()[1] if onset_search is not None else None,
        q_max=q_max,
        geometry=ss.geometry,
        degenerate=ss.dt_safe == 0,
        dt_tangent=dt_tan,
        recommended_dt=math.nan if recommend is None else recommend(pot, m, v0, kind),
        lane_steps=lane_steps,
        engine=used,
        failure_kind=fk,
        dt_bounded=dt_b,
        bounded_E_max_over_E0=peak_b,
        dt_accuracy=acc,
        accuracy_ratio=None if acc is None else (acc / ss.dt_safe if ss.dt_safe > 0 else math.inf),
        runaway_evidence=s.evidence.get(f) if fk == "runaway" else None,
        extra=extra,
    )


def search_scene(
    potential: Potential,
    m: float,
    velocities: Sequence[float] | float,
    kind: str,
    *,
    gap: float | None = None,
    zeta: float | None = None,
    criterion: Criterion | None = None,
    grid: SearchGrid = _DEFAULT_GRID,
    progress: Callable[[float, float], None] | None = None,
    engine: str = "auto",
    recommend: Callable | None | str = "default",
) -> list[DtCritResult]:
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
        "default" is `reference_impl.stability.recommend.recommended_step`, None leaves NaN.

    Returns
    -------
    list of DtCritResult
        One per speed, in the given order.
    """
    vs, z, crit = _validated(potential, m, velocities, kind, gap, zeta, criterion)
    if isinstance(recommend, str):
        from reference_impl.stability.recommend import recommended_step as recommend
    info, searches, main_of = [], [], []
    for v0 in vs:
        ss = _dt_safe(potential, m, v0)
        q_max = potential.turning_point(0.5 * m * v0 * v0, check=False)
        dt_tan = tangent_step(potential, m, q_max)
        ref = ss.dt_safe if ss.dt_safe > 0 else (dt_tan if dt_tan > 0 else ss.dt_shortcut)
        g = 0.0 if kind != "two-walls" else (_DEFAULT_GAP_QMAX * q_max if gap is None else gap)
        if kind == "two-walls" and math.ulp(g + q_max) > _GAP_ULP_RTOL * q_max:
            raise HCVInputError(
                f"two-walls gap = {g:.6g} m is too large for the overlap q_max = {q_max:.3g} m at "
                f"v0 = {v0!r} m/s: positions near the gap are float64 numbers {math.ulp(g + q_max):.3g}"
                f" m apart, more than {_GAP_ULP_RTOL:g} q_max, so the overlap is not resolved; "
                f"use a gap below {_GAP_ULP_RTOL * q_max / np.finfo(float).eps:.3g} m"
            )
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
        for part in _chunks(searches, need, MAX_LANES_PER_CALL):
            batch, owners, _ = _build(
                searches,
                part,
                kind,
                potential,
                m,
                [o[1] for o in owner_info],
                [o[3] for o in owner_info],
                crit,
            )
            res = run_lanes(potential, m, scene, batch, zeta=z, skip_after_fail=True, engine=engine)
            lane_steps += int(res.steps.sum())
            used = res.engine
            _record(searches, owners, batch, res, m)
        if progress is not None:
            progress(sum(_progress_fraction(s, grid) for s in searches), float(len(searches)))
    out = []
    for j, v0 in enumerate(vs):
        ss, q_max, dt_tan, g = info[j]
        s = searches[main_of[j]]
        lo, f = s.bracket()
        out.append(
            _result(
                potential,
                m,
                v0,
                kind,
                crit,
                ss,
                q_max,
                dt_tan,
                g,
                z,
                engine,
                s,
                searches[main_of[j] + 1] if kind == "impact" else None,
                lo,
                f,
                recommend,
                lane_steps,
                used,
            )
        )
    if progress is not None:
        progress(float(len(searches)), float(len(searches)))
    return out
