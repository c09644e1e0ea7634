"""The critical step of velocity Verlet on an assembly: one search, or an ensemble's distribution.

Every lane of an ensemble starts from the same state but for the last bits of its
velocities (lane k scales them by 1 + k 2^-52) and has its own bracket search, the
suite's (`reference_impl.stability.steps.search_steps`: scan, extension, k-section); all
the lanes a round needs run in one call of the compiled kernel. A lane fails at a step
when it runs away under the `EnergyGrowth` rule (E_n > factor E_0 within the horizon,
confirmed by confirm_level E_0 within confirm_horizon horizons, or blown); its Delta
t_crit is the smallest failing step found. For a linear bonded assembly the lanes agree
and one lane is the measurement (`reference_impl.assembly.linear` gives 2 / omega_max);
where contacts open and close the lanes' Delta t_crit differ, and what is reported is their
distribution: P_fail(dt) (the fraction of lanes whose Delta t_crit is <= dt) and its
5 / 50 / 95 % points, at each horizon asked.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from reference_impl.assembly.lanes import ULP_SCALE, AssemblyModel, initial_energy, run_lanes
from reference_impl.assembly.safe import dt_safe_conventions, tangent_step
from reference_impl.errors import HCVInputError
from reference_impl.integrators.verlet_kernel import STATUS_NAMES
from reference_impl.stability.bound import dt_safe_shortcut
from reference_impl.stability.criteria import EnergyGrowth, SearchGrid
from reference_impl.stability.steps import search_steps

__all__ = [
    "HORIZONS",
    "MAX_ENSEMBLE",
    "QUANTILES",
    "Ensemble",
    "assembly_report",
    "reference_step",
    "search_ensemble",
]

# The horizons of the issue (steps): the report's; the test suite passes shorter ones.
HORIZONS = (10_000, 100_000, 1_000_000)
QUANTILES = (0.05, 0.50, 0.95)
# Lanes of one ensemble: each is a search of its own (a few hundred lanes of the kernel).
MAX_ENSEMBLE = 1024
# The default scan: the single-contact search's own (so that one body between two walls
# gives its numbers exactly). Each lane costs a full horizon at every stable step it tries:
# a 1e6-step ensemble of a ten-body chain is ~1e10 contact updates (minutes); tests pass
# coarser grids and shorter horizons.
ENSEMBLE_GRID = SearchGrid()


@dataclass(frozen=True)
class Ensemble:
    """Delta t_crit of each lane of an ensemble at one horizon.

    Attributes
    ----------
    horizon : int
        Steps a lane runs before it counts as stable (the criterion's n_steps).
    dt_crit, dt_stable : numpy.ndarray
        Per lane: the smallest failing step and the largest stable step below it (s);
        inf where no step failed up to the search's limit.
    evidence : list
        Per lane: "confirmed", "domain" or None (no failure).
    q_run : float
        Largest overlap met by a lane at a stable step (m), for the tangent step.
    contact_updates : int
        Lanes x steps x contacts integrated.
    criterion : str
        The failure rule.
    """

    horizon: int
    dt_crit: np.ndarray
    dt_stable: np.ndarray
    evidence: list
    q_run: float
    contact_updates: int
    criterion: str

    def quantiles(self) -> dict[str, float]:
        """The 5 / 50 / 95 % points of Delta t_crit over the lanes (s), keys "5", "50", "95"."""
        d = np.sort(self.dt_crit)
        return {f"{round(100 * p)}": float(np.quantile(d, p, method="lower")) for p in QUANTILES}

    def p_fail(self) -> list[tuple[float, float]]:
        """P_fail(dt): (dt (s), fraction of lanes with Delta t_crit <= dt) at each lane's value."""
        d = np.sort(self.dt_crit[np.isfinite(self.dt_crit)])
        n = self.dt_crit.size
        return [(float(x), float((k + 1) / n)) for k, x in enumerate(d)]


def search_ensemble(
    model: AssemblyModel,
    dt_ref: float,
    *,
    n_lanes: int = 32,
    criterion: EnergyGrowth | None = None,
    grid: SearchGrid = ENSEMBLE_GRID,
    progress: Callable[[float, float], None] | None = None,
    first_lane: int = 0,
) -> Ensemble:
    """Delta t_crit of ``n_lanes`` lanes whose initial velocities differ in their last bits.

    Parameters
    ----------
    model : AssemblyModel
        The assembly, its law and its initial state.
    dt_ref : float
        Reference step of the scan (s), e.g. Delta t_safe.
    n_lanes : int
        Lanes (1 .. `MAX_ENSEMBLE`); lane k scales the initial velocities by 1 + k 2^-52.
    criterion : EnergyGrowth, optional
        The runaway rule and horizon (its n_steps); default `EnergyGrowth()`.
    grid : SearchGrid
        Scan and refinement in units of ``dt_ref``.
    progress : callable, optional
        ``progress(completed, total)`` after each round, and again with the same values
        between the kernel's calls within a round (a long horizon's round is minutes: the
        progress line and a sweep case's deadline get through).
    first_lane : int
        Index of the first lane in its ensemble (>= 0): lanes first_lane .. first_lane +
        n_lanes - 1 of a larger ensemble, each as it is there (a sweep runs an ensemble in
        groups of lanes, `reference_impl.sweep._assembly`).
    """
    if (
        not isinstance(n_lanes, int)
        or isinstance(n_lanes, bool)
        or not 1 <= n_lanes <= MAX_ENSEMBLE
    ):
        raise HCVInputError(f"n_lanes must be an integer in [1, {MAX_ENSEMBLE}], got {n_lanes!r}")
    if not (math.isfinite(dt_ref) and dt_ref > 0):
        raise HCVInputError(f"reference step must be finite and > 0 (s), got {dt_ref!r}")
    crit = EnergyGrowth() if criterion is None else criterion
    if not isinstance(crit, EnergyGrowth):
        raise HCVInputError(f"an assembly needs an EnergyGrowth criterion, got {crit!r}")
    if isinstance(first_lane, bool) or not isinstance(first_lane, int) or first_lane < 0:
        raise HCVInputError(f"first_lane must be an integer >= 0, got {first_lane!r}")
    scale = 1.0 + ULP_SCALE * np.arange(first_lane, first_lane + n_lanes)
    work = {"updates": 0, "q_run": 0.0}
    last = [0.0, float(n_lanes)]  # the latest (completed, total) of the rounds

    def rounds(done: float, total: float) -> None:
        last[:] = [done, total]
        if progress is not None:
            progress(done, total)

    def between_calls(_updates: int) -> None:
        if progress is not None:
            progress(*last)

    def evaluate(need: dict) -> dict:
        owners = np.concatenate([np.full(d.size, i) for i, d in need.items()])
        dts = np.concatenate(list(need.values()))
        out = run_lanes(
            model,
            dts,
            scale[owners],
            factor=crit.factor,
            confirm_level=crit.confirm_level,
            n_steps=int(crit.n_steps),
            confirm_steps=crit.confirm_steps,
            progress=between_calls,
        )
        work["updates"] += out.contact_updates
        failed, bounded = out.failed, out.bounded
        stable = ~failed
        if np.any(stable):
            work["q_run"] = max(work["q_run"], float(np.max(out.q_max[stable])))
        blown = out.status == STATUS_NAMES.index("blown")
        rows: dict = {i: [] for i in need}
        for k, i in enumerate(owners):
            peak = float(out.e_max[k] / out.e0[k]) if bounded[k] else None
            ev = ("domain" if blown[k] else "confirmed") if failed[k] else None
            rows[int(i)].append((float(dts[k]), bool(failed[k]), ev, peak))
        return rows

    searches = search_steps(evaluate, [dt_ref] * n_lanes, grid, rounds)
    brackets = [s.bracket() for s in searches]
    dt_crit = np.array([f for _, f in brackets])
    return Ensemble(
        horizon=int(crit.n_steps),
        dt_crit=dt_crit,
        dt_stable=np.array([lo for lo, _ in brackets]),
        evidence=[s.evidence.get(f) for s, (_, f) in zip(searches, brackets, strict=False)],
        q_run=work["q_run"],
        contact_updates=work["updates"],
        criterion=crit.describe(),
    )


def assembly_report(
    model: AssemblyModel,
    *,
    horizons: Sequence[int] = HORIZONS,
    n_lanes: int = 32,
    factor: float = 100.0,
    confirm_factor: float = 1e4,
    confirm_horizon: int = 10,
    grid: SearchGrid = ENSEMBLE_GRID,
    progress: Callable[[float, float], None] | None = None,
) -> dict:
    """Everything ``hcv dt-crit`` reports for an assembly scene (JSON-safe dict, SI units).

    Fields: ``dt_safe`` (the three conventions of `reference_impl.assembly.safe`), ``e0``
    (J), ``n_bodies``, ``n_contacts``, ``coordination`` (Z), ``dim``, ``geometry`` (the
    contacts' model: "lines of centres" or "fixed normals"), ``n_lanes``,
    ``by_horizon`` (per horizon: the 5 / 50 / 95 % points of Delta t_crit (s) and over
    Delta t_safe (paper), P_fail(dt), the tangent-stiffness step along the run, the
    lanes' evidence counts, the contact updates, and the unperturbed lane 0's bracket
    ``dt_stable_lane0``, ``dt_crit_lane0``: one body between two walls gives there the
    single-contact search's numbers), ``horizon_dependent`` (the median at the
    longest horizon lies below the 5 % point at the shortest: the failing step falls as
    the run gets longer), ``holds`` (the paper's Delta t_safe is below the 5 % point at
    every horizon), and ``factor`` (5 % point at the longest horizon over Delta t_safe:
    by how much Delta t_safe must be reduced where it is below 1).
    """
    hs = sorted({int(h) for h in horizons})
    if not hs:
        raise HCVInputError("give at least one horizon (steps)")
    out_rows = []
    e0 = None
    safe = None
    total = float(len(hs))
    for k, h in enumerate(hs):
        crit = EnergyGrowth(
            factor=factor, n_steps=h, confirm_factor=confirm_factor, confirm_horizon=confirm_horizon
        )
        if safe is None:
            e0, safe, ref = reference_step(model)

        def sub(done: float, tot: float, k=k) -> None:
            if progress is not None:
                progress(k + done / max(tot, 1.0), total)

        ens = search_ensemble(model, ref, n_lanes=n_lanes, criterion=crit, grid=grid, progress=sub)
        qs = ens.quantiles()
        paper = safe["paper"]
        out_rows.append(
            {
                "horizon": h,
                "dt_crit_lane0": float(ens.dt_crit[0]),
                "dt_stable_lane0": float(ens.dt_stable[0]),
                "dt_crit_quantiles": qs,
                "dt_crit_over_dt_safe": {
                    p: (v / paper if paper > 0 else math.inf) for p, v in qs.items()
                },
                "p_fail": ens.p_fail(),
                "dt_tangent": tangent_step(model.assembly, model.potential, ens.q_run),
                "q_run": ens.q_run,
                "failures": {
                    "confirmed": sum(e == "confirmed" for e in ens.evidence),
                    "domain": sum(e == "domain" for e in ens.evidence),
                    "none": sum(e is None for e in ens.evidence),
                },
                "contact_updates": ens.contact_updates,
                "criterion": ens.criterion,
            }
        )
    first, last = out_rows[0]["dt_crit_quantiles"], out_rows[-1]["dt_crit_quantiles"]
    paper = safe["paper"]
    a = model.assembly
    return {
        "assembly": True,
        "dim": a.dim,
        "n_bodies": a.n_bodies,
        "n_contacts": a.n_contacts,
        "coordination": a.coordination,
        "bonded": bool(model.bonded),
        "geometry": "fixed normals" if model.kernel_lengths() is None else "lines of centres",
        "e0": e0,
        "dt_safe": safe,
        "n_lanes": n_lanes,
        "perturbation": "lane k: initial velocities times 1 + k 2^-52",
        "by_horizon": out_rows,
        "horizon_dependent": bool(len(out_rows) > 1 and last["50"] < first["5"]),
        "holds": bool(all(r["dt_crit_quantiles"]["5"] >= paper for r in out_rows)),
        "factor": (last["5"] / paper) if paper > 0 else math.inf,
    }


def reference_step(model: AssemblyModel) -> tuple[float, dict[str, float], float]:
    """(E_0 (J), Delta t_safe under each convention (s), the search's reference step (s)):
    the paper's Delta t_safe, or where it is 0 the endpoint shortcut (`_fallback_ref`)."""
    e0 = initial_energy(model)
    safe = dt_safe_conventions(model, e0)
    ref = safe["paper"] if safe["paper"] > 0 else _fallback_ref(model, e0)
    return e0, safe, ref


def _fallback_ref(model: AssemblyModel, e0: float) -> float:
    """A reference step where Delta t_safe is 0 (U'/sqrt(2U) unbounded at contact): the
    section 6 endpoint shortcut 2 m v / U'(q_max) of the striker holding all of E_0."""
    b = int(np.argmax(np.linalg.norm(model.v_init, axis=1)))
    m = float(model.assembly.mass[b])
    return dt_safe_shortcut(model.potential, m, math.sqrt(2.0 * e0 / m))
