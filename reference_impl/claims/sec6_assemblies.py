"""Section 6 where DEM lives: does Delta t_safe <= Delta t_crit hold in chains and packings?

The conclusion (section 11) says the bound makes empirical timestep tuning unnecessary in
granular mechanics and DEM, where a run is many contacts at once. Measured here on undamped
Hertz assemblies (the hertz scene's steel spheres: k = 1.0879e10 N/m^1.5, m = 4.1103e-3 kg,
striker at 1 m/s, touching, no damping), with the assembly kernel and the suite's search
(`reference_impl.assembly.search`): per case an ensemble of `N_LANES` lanes whose initial
velocities differ in the last bits, each lane's Delta t_crit (runaway: E_n > 100 E_0 within
the horizon, confirmed at 1e6 E_0), and the 5 % point of their distribution over the
paper's Delta t_safe (striker's mass and energy). The factor by which Delta t_safe must be
reduced is that ratio where it is below 1; beside it the linear prediction sqrt(d / (2 Z)),
the ratio of 2 / omega_max of a lattice of coordination Z in d dimensions to the single
contact's 2 sqrt(m / k).

The lattices' contacts follow their lines of centres (finite displacements,
`reference_impl.assembly.geometry`), as LIGGGHTS, LAMMPS and YADE do: the kernel's
positions are theirs to round-off at this striker (1e-16 m over 300 steps,
`verification/test_assembly_codes_lattice.py`), so the lattice rows carry the codes' model
and the verdict rests on the chains and the lattices alike (a chain's lines of centres
cannot turn: the same in either model). The kernel keeps its contact list (no contact is
ever made anew), the codes do not (neighbour lists): a row counts only where lane 0, run
for the whole horizon at its largest stable step, keeps every body within its cage
(`reference_impl.assembly.lanes.cage_fraction` < 1: no pair outside the list can touch).
Measured, the touching square and honeycomb layers (no confining pressure) come apart:
their bodies leave their cages within ~1e3 steps, so those rows are reported and left
out of the verdict.

The horizons: each report run measures 1e4 and 1e5 steps; the issue's 1e6 steps cost
minutes of CPU per case and are measured once by `reference_impl.campaign.assembly_long`
(the same search, lanes, grid, criterion and model: `case_model`, `record_settings`) into
the record ``reports/assemblies_1e6.json``. The full measurement reads it as hostile input
(`reference_impl.claims._assembly_record.read_record`) and merges its horizon into every
case it holds (`merge_record`): the quantiles, P_fail, factor and tangent step are then the
1e6 ones, ``holds`` and ``horizon_dependent`` are judged over the three horizons, and the
evidence names the record's commit and date. A record that fails a check is ignored with
one line in the evidence ("1e6 record ignored: <why>"); the quick measurement never reads it.
"""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np

from reference_impl.assembly.geometry import chain, lattice
from reference_impl.assembly.lanes import AssemblyModel, cage_fraction
from reference_impl.assembly.model import STRIKER_DIRECTION
from reference_impl.assembly.search import assembly_report
from reference_impl.claims._assembly_record import (
    LONG_HORIZON,
    RECORD_PATH,
    ensemble_of,
    read_record,
)
from reference_impl.claims._base import Measurement, g
from reference_impl.potentials import PowerLaw
from reference_impl.stability.criteria import SearchGrid

__all__ = [
    "CRITERION", "GRID", "HERTZ", "ID", "N_LANES", "PRINTED", "SECTION", "STATEMENT", "case_model",
    "cases", "corrected", "measure", "measurement_from_rows", "merge_record", "record_settings",
]  # fmt: skip

ID = "sec6-assemblies"
SECTION = "6, 11"
STATEMENT = (
    "The closed-form bound Delta t_safe is a rigorous sufficient condition for the stability "
    "of velocity Verlet, eliminating empirical timestep tuning in granular mechanics and DEM "
    "(here: chains and packings of Hertz contacts)."
)
PRINTED = (
    "section 11 (Conclusion)",
    None,
    r"Second, it yields a rigorous closed-form sufficient bound for numerical stability, "
    r"eliminating the need for empirical timestep tuning.",
)

# The hertz scene's steel sphere (reference_impl/scenes/hertz.toml), struck at 1 m/s:
# k (N/m^1.5), p, mass (kg), radius (m), striker speed (m/s).
HERTZ = (1.0879e10, 1.5, 4.1103e-3, 5.0e-3, 1.0)
_K, _P, _MASS, _RADIUS, _V0 = HERTZ
# Lanes of each ensemble: the minimum; their spread is what a verdict rests on.
N_LANES = 32
# Horizons (steps). Quick: one short horizon (the test suite, ~seconds).
QUICK_HORIZONS = (1_000,)
# Full: the two the report can afford for every case (~1e10 contact updates); the issue's
# third, 1e6 steps (`LONG_HORIZON`), is read from the record `RECORD_PATH` that
# `reference_impl.campaign.assembly_long` writes with this module's settings.
FULL_HORIZONS = (10_000, 100_000)
# Scan from 0.05 to 2 Delta t_safe in steps of 0.05, bracket to 0.2 % of Delta t_safe: the
# lanes' spread at a horizon (several % in the measurements) is wider than the bracket.
GRID = SearchGrid(lo=0.05, hi=2.0, step=0.05, resolution=2e-3, refine_points=4)
# The bound holds in a case when the 5 % point of Delta t_crit is at or above Delta t_safe:
# 95 % of the lanes are stable at Delta t_safe. No tolerance: the bracket (GRID.resolution
# of Delta t_safe) is the only error, and it lies on the failing side (smallest failing step).
HOLD_QUANTILE = "5"
# The runaway rule (`assembly_report`'s keywords): E_n > 100 E_0 within the horizon,
# confirmed by 1e4 x that (1e6 E_0) within 10 horizons.
CRITERION = {"factor": 100.0, "confirm_factor": 1e4, "confirm_horizon": 10}


def cases(quick: bool = False) -> list[tuple[str, int, float, object]]:
    """(label, dimension d, coordination Z, Assembly) of the measured assemblies.

    Full: chains of 1 to 10 spheres, 4 x 4 periodic 2-D lattices, and one conventional cell
    of each 3-D lattice in a walled box (every sphere has its Z contacts, walls counted;
    a periodic 2 x 2 x 2 fcc box costs ~1e10 contact updates per ensemble at 1e5 steps).
    """
    out = [(f"chain N={n}, walls both", n) for n in ((2, 5) if quick else (1, 2, 5, 10))]
    rows = [(label, 1, 2.0, chain([_MASS] * n, "both", 0.0)) for label, n in out]
    names = ("square", "triangular") if quick else ("honeycomb", "square", "triangular")
    cells = 2 if quick else 4
    for name in names:
        asm = lattice(name, cells, _MASS, _RADIUS)
        rows.append((f"{name} {cells}x{cells}, periodic", 2, asm.coordination, asm))
    if not quick:
        for name in ("simple-cubic", "bcc", "fcc"):
            asm = lattice(name, 1, _MASS, _RADIUS, periodic=False)
            rows.append((f"{name} 1 cell, walled", 3, asm.coordination, asm))
    return rows


def case_model(asm) -> AssemblyModel:
    """The assembly with the striker (body 0) at v0 (along `STRIKER_DIRECTION` in a lattice).

    Parameters
    ----------
    asm : reference_impl.assembly.geometry.Assembly
        One of `cases`' assemblies.
    """
    v = np.zeros((asm.n_bodies, asm.dim))
    if asm.dim == 1:
        v[0, 0] = _V0
    else:
        d = STRIKER_DIRECTION[asm.dim]
        v[0] = _V0 * d / np.linalg.norm(d)
    pot = PowerLaw(_K, _P)
    return AssemblyModel(asm, pot, False, 0.0, 0.0, v, np.zeros((asm.n_bodies, 0)))


def _steps(n: int) -> str:
    """A horizon as the issue writes it: 1e6 for 1 000 000 steps, else with separators."""
    k = len(str(n)) - 1
    return f"1e{k}" if n == 10**k else f"{n:,}"


def record_settings() -> dict:
    """The claim's settings as the long-horizon record holds them (JSON-ready): lanes, the
    search grid (units of Delta t_safe), the runaway criterion, the potential (N/m^p), the
    masses (kg), the lattices' radius (m), the striker's speed (m/s), the perturbation."""
    return {
        "n_lanes": N_LANES,
        "grid": dataclasses.asdict(GRID),
        "criterion": dict(CRITERION),
        "potential": {"family": "power", "k": _K, "p": _P},
        "mass": _MASS,
        "radius": _RADIUS,
        "v0": _V0,
        "damping": None,
        "perturbation": "lane k: initial velocities times 1 + k 2^-52",
    }


def _row(label: str, d: int, z: float, asm, horizons) -> dict:
    """One case's row at the claim's own horizons (`assembly_report`)."""
    model = case_model(asm)
    rep = assembly_report(model, horizons=horizons, n_lanes=N_LANES, grid=GRID, **CRITERION)
    last = rep["by_horizon"][-1]
    cage = cage_fraction(model, last["dt_stable_lane0"], last["horizon"])
    return {
        "case": label,
        "n_bodies": asm.n_bodies,
        "n_contacts": asm.n_contacts,
        "dim": d,
        "coordination": z,
        "dt_safe": rep["dt_safe"],
        "horizon": last["horizon"],
        "ratio_by_horizon": {
            str(r["horizon"]): r["dt_crit_over_dt_safe"] for r in rep["by_horizon"]
        },
        # the 5 / 50 / 95 % points of Delta t_crit (s) per horizon: the flags' own numbers
        "dt_crit_by_horizon": {
            str(r["horizon"]): r["dt_crit_quantiles"] for r in rep["by_horizon"]
        },
        # P_fail(dt) per horizon: (dt (s), fraction of lanes failed), the report's curves
        "p_fail_by_horizon": {str(r["horizon"]): r["p_fail"] for r in rep["by_horizon"]},
        "ratio_5": last["dt_crit_over_dt_safe"]["5"],
        "ratio_50": last["dt_crit_over_dt_safe"]["50"],
        "ratio_95": last["dt_crit_over_dt_safe"]["95"],
        "tangent_ratio": last["dt_tangent"] / rep["dt_safe"]["paper"],
        "linear_prediction": math.sqrt(d / (2.0 * z)),
        "horizon_dependent": rep["horizon_dependent"],
        "holds": rep["holds"],
        "factor": min(1.0, rep["factor"]),
        # largest body displacement over its cage, lane 0 at its largest stable step
        "cage_fraction": cage,
        "contact_list_held": cage < 1.0,
        "from_record": False,
    }


def _expected(rows: list[dict]) -> dict:
    """What the record must agree with, per case label: the assembly's shape and the
    paper's Delta t_safe (s) of the claim's model."""
    keys = ("n_bodies", "n_contacts", "dim", "coordination")
    return {r["case"]: {**{k: r[k] for k in keys}, "dt_safe": r["dt_safe"]["paper"]} for r in rows}


def merge_record(rows: list[dict], record: dict | None, why: str | None = None):
    """The rows with the record's long horizon merged in, and what the evidence says of it.

    Parameters
    ----------
    rows : list of dict
        The claim's rows at its own horizons (each with ``dt_crit_by_horizon``).
    record : dict or None
        `reference_impl.claims._assembly_record.read_record`'s checked record; None when it
        was ignored (``why`` says why) or not read.
    why : str, optional
        Why the record was ignored.

    Returns
    -------
    (list of dict, dict)
        New rows (the inputs are not changed): where the record has the case, its horizon
        is added to ``ratio_by_horizon``, ``dt_crit_by_horizon`` and ``p_fail_by_horizon``;
        the 5 / 50 / 95 % points, ``tangent_ratio``, ``horizon`` and ``factor`` are the long
        horizon's; ``holds`` is the 5 % point at or above Delta t_safe at every horizon,
        ``horizon_dependent`` the median at the longest below the 5 % point at the shortest
        (as `assembly_report`), ``cage_fraction`` the larger of the two runs'. And the
        ``long_horizon`` summary: ``source``, ``horizon``, ``commit``, ``date``,
        ``git_dirty`` (of the record's first run), ``merged`` (case labels), ``runs`` (the
        runs that measured them: ``commit``, ``date``, ``git_dirty``, ``cases``),
        ``left_out`` (label -> why), ``note`` (the
        one line "1e6 record ignored: <why>", or None).
    """
    where = "reports/" + RECORD_PATH.name
    if record is None:
        note = f"{_steps(LONG_HORIZON)} record ignored: {why}" if why else None
        return [dict(r) for r in rows], {"source": where, "merged": [], "note": note}
    out, merged = [], []
    runs: list = []  # ((commit, date, git_dirty), cases) of the runs that measured them
    for r in rows:
        case = record["cases"].get(r["case"])
        if case is None:
            out.append(dict(r))
            continue
        ens = ensemble_of(case)
        qs = ens.quantiles()
        paper = float(r["dt_safe"]["paper"])
        h = str(LONG_HORIZON)
        dts = {**r["dt_crit_by_horizon"], h: qs}
        first = dts[min(dts, key=int)]
        cage = max(float(r["cage_fraction"]), case["cage_fraction"])
        out.append(
            {
                **r,
                "horizon": LONG_HORIZON,
                "ratio_by_horizon": {**r["ratio_by_horizon"], h: {p: v / paper for p, v in qs.items()}},
                "dt_crit_by_horizon": dts,
                "p_fail_by_horizon": {**r["p_fail_by_horizon"], h: ens.p_fail()},
                "ratio_5": qs["5"] / paper,
                "ratio_50": qs["50"] / paper,
                "ratio_95": qs["95"] / paper,
                "tangent_ratio": case["dt_tangent"] / paper,
                "horizon_dependent": bool(qs["50"] < first["5"]),
                "holds": bool(all(q["5"] >= paper for q in dts.values())),
                "factor": min(1.0, qs["5"] / paper),
                "cage_fraction": cage,
                "contact_list_held": cage < 1.0,
                "from_record": True,
            }
        )  # fmt: skip
        merged.append(r["case"])
        run = (case["commit"], case["date"], case["git_dirty"])
        if not runs or runs[-1][0] != run:
            runs.append((run, []))
        runs[-1][1].append(r["case"])
    info = {
        "source": where,
        "horizon": LONG_HORIZON,
        "commit": record["commit"],
        "date": record["date"],
        "git_dirty": record["git_dirty"],
        "merged": merged,
        "runs": [
            {"commit": c, "date": d, "git_dirty": dirty, "cases": names}
            for (c, d, dirty), names in runs
        ],
        "left_out": dict(record["left_out"]),
        "note": None,
    }
    return out, info


def _provenance(long: dict) -> str:
    """The record's run(s) for the evidence: "commit X, date", or per run its cases too."""
    runs = long.get("runs") or [dict(long, cases=long["merged"])]

    def one(run: dict) -> str:
        dirty = ", uncommitted changes" if run.get("git_dirty") else ""
        return f"commit {run['commit'][:12]}{dirty}, {run['date']}"

    if len(runs) == 1:
        return one(runs[0])
    return "; ".join(f"{', '.join(run['cases'])}: {one(run)}" for run in runs)


@functools.cache
def measure(quick: bool = False) -> Measurement:
    """Refuted when the 5 % point of an ensemble's Delta t_crit lies below the paper's
    Delta t_safe (at any horizon) in any case that kept its contact list, verified
    otherwise. Full: the claim's horizons, and the long horizon from the record
    (`RECORD_PATH`) where it is present and agrees with the claim; quick reads no record."""
    horizons = QUICK_HORIZONS if quick else FULL_HORIZONS
    rows = [_row(label, d, z, asm, horizons) for label, d, z, asm in cases(quick)]
    long = None
    if not quick:
        record, why = read_record(RECORD_PATH, record_settings(), _expected(rows))
        rows, long = merge_record(rows, record, why)
    return measurement_from_rows(rows, horizons, long)


def measurement_from_rows(rows: list[dict], horizons, long: dict | None = None) -> Measurement:
    """The claim's verdict and evidence from its rows (`merge_record`'s, with ``long``).

    Parameters
    ----------
    rows : list of dict
        One per case (`measure`'s fields).
    horizons : sequence of int
        The claim's own horizons (steps).
    long : dict, optional
        `merge_record`'s summary of the long-horizon record (None: not read, quick).
    """
    merged = list((long or {}).get("merged") or [])
    all_h = [*horizons, LONG_HORIZON] if merged else list(horizons)
    counted = [r for r in rows if r["contact_list_held"]]
    bad = [r for r in counted if not r["holds"]]
    left = [r["case"] for r in rows if not r["contact_list_held"]]
    worst = min(counted, key=lambda r: r["ratio_5"])
    verdict = "refuted" if bad else "verified"
    if merged:
        src = (
            f"; {_steps(LONG_HORIZON)}-step horizon of {', '.join(merged)} from the record "
            f"{long['source']} ({_provenance(long)})"
            + "".join(
                f"; {c} not in that record ({why})"
                for c, why in (long.get("left_out") or {}).items()
                if any(r["case"] == c for r in counted)
            )
        )
    else:
        src = f"; {long['note']}" if long and long.get("note") else ""
    evidence = (
        f"5 % point of Delta t_crit / Delta t_safe over {N_LANES} lanes at the longest horizon: "
        + ", ".join(
            f"{r['case']} {g(r['ratio_5'], 3)} at {_steps(r['horizon'])} "
            f"(sqrt(d/2Z) {g(r['linear_prediction'], 3)})"
            for r in rows
        )  # fmt: skip
        + f"; bound fails in {len(bad)} of {len(counted)} cases that kept their contact list"
        + (f" (left out: {', '.join(left)}, bodies left their cages)" if left else "")
        + src
    )
    figures = {"rows": rows, "horizons": all_h, "n_lanes": N_LANES, "worst": worst["case"]}
    if long is not None:
        figures["long_horizon"] = long
    return Measurement(
        ID,
        verdict,
        evidence,
        f"refuted if in any case the {HOLD_QUANTILE} % point of the lanes' Delta t_crit lies "
        f"below the paper's Delta t_safe (striker's mass and energy) at any horizon "
        f"{list(all_h)}"
        + (f" ({LONG_HORIZON} steps from the record, where it has the case)" if merged else "")
        + "; runaway: E_n > 100 E_0 within the horizon, confirmed at 1e6 E_0; "
        "contacts along their current lines of centres (the codes' model); a case counts only "
        "if lane 0 at its largest stable step keeps every body in its cage over the horizon",
        figures,
        {"case": worst["case"], "ratio_5": worst["ratio_5"], "horizon": worst["horizon"]}
        if bad
        else None,
        headline=(
            f"Delta t_crit (5 %) / Delta t_safe down to {g(worst['ratio_5'], 3)} "
            f"({worst['case']}, {_steps(worst['horizon'])} steps); reduce by that factor"
        ),
    )


def corrected(m: dict, r: dict) -> tuple[str, str]:
    """The corrected statement and its numbers, read from the claim's measured figures."""
    rows = [x for x in m["rows"] if x.get("contact_list_held", True)]  # the verdict's rows
    worst = min(rows, key=lambda x: x["ratio_5"])
    return (
        "Not a sufficient condition in assemblies: in undamped Hertz chains and packings "
        f"velocity Verlet runs away below Delta t_safe; take Delta t <= {g(worst['ratio_5'], 3)} "
        f"Delta t_safe (the smallest measured 5 % point, {worst['case']}, "
        f"{_steps(worst['horizon'])} steps), and expect the linear scaling sqrt(d / (2 Z)).",
        "; ".join(
            f"{x['case']}: {g(x['ratio_5'], 3)} (linear {g(x['linear_prediction'], 3)})"
            for x in rows
        ),
    )
