"""Work-precision of the exact solvers and their peers: CPU time against achieved error (issue 38, goal 2).

Ours is a curve since the solvers take ``rtol`` (`reference_impl.exact._rtol`): for each
panel (`PANELS`: each family under the universal law and a linear dashpot, and Hertz under
Hunt-Crossley) and each rtol of `OURS_RTOLS` (1e-6 ..
1e-14, then None: full accuracy), the one-shot call (``solve(pot, m, v0, zeta, rtol=)``
or ``solve(pot, m, v0, law=, rtol=)``) and the prepared call (``prepare(pot, m,
rtol=)``, built outside the timing, as the peers' tables are) over a set of random
impacts (`benchmarks._equal_error.random_impacts`: speeds 0.1-10 m/s, zeta in [0, 0.85]
or the law's strength 0.1-1x its calibrated value); each peer of `benchmarks._peers`
(plain DOP853, the q sqrt(q) DOP853, the Sundman-regularised DOP853 on power laws,
numbalsoda where installed) over its tolerance ladder `PEER_RTOLS`.

Achieved error: the largest relative error over the set and over the outputs `KEYS`
(both ends' contact time and restitution, q_max), against ours at full accuracy (the
proxy truth of `benchmarks._equal_error`; its distance to the 30-digit truth is checked
on ``--mp-subset`` impacts and recorded); a point below the proxy's own resolution is
drawn at `ERROR_FLOOR`. Ours also records its largest reported bound (relative), which
must be at most its rtol and at least its achieved error.

Timing: CPU time (`time.process_time`) of one pass over the whole set per contestant,
every point of a panel interleaved block by block (`benchmarks.bench_exact._interleaved`),
median of the blocks, per impact. The JSON (`SCHEMA`) records the load average before
and after, the machine and the commit; the figure is log-log, one panel per family and
law.

Run: ``python -m benchmarks.bench_workprecision [--json reports/bench/workprecision.json]
[--png reports/bench/workprecision.png] [--impacts N] [--blocks N] [--mp-subset N]``;
``--figure-from JSON --png PNG`` redraws the figure from a record without running.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

from reference_impl import Ellipsoid, PowerLaw, Sphere, prepare, solve
from reference_impl.errors import HCVInputError, UnsupportedError
from reference_impl.scenes import load_scene
from reference_impl.studies.laws import hertz

from ._equal_error import IMPACTS, check_proxy, random_impacts, set_ladder
from ._machine import machine_info
from ._peers import PEER_LABELS, peer_cases
from ._record import write_json
from .bench_exact import _interleaved, _load

__all__ = [
    "HUNT_CROSSLEY",
    "LAW",
    "OURS_RTOLS",
    "PEER_RTOLS",
    "SCHEMA",
    "UNIVERSAL",
    "figure",
    "main",
    "panel",
    "panels",
    "run",
    "trades",
]

SCHEMA = "hcv-bench-workprecision/1"
# Ours: the accuracy asked, 1e-6 .. 1e-14, then full accuracy (None).
OURS_RTOLS = (*(10.0**-k for k in range(6, 15)), None)
# The peers' ladder: rtol = 10^(-k/2), 1e-5 .. 1e-16 (atol scaled with the impact).
PEER_RTOLS = tuple(10.0 ** (-k / 2) for k in range(10, 33))
# The outputs compared (names of `benchmarks._peers.outputs` and of the solutions).
KEYS = (
    "contact_time",
    "restitution",
    "contact_time_zero_force",
    "restitution_zero_force",
    "max_penetration",
)
# Errors are measured against ours at full accuracy (~1e-16 relative, bounded): an
# error below this is below the proxy's resolution and drawn here.
ERROR_FLOOR = 1e-16
# The general law of the panels: a linear dashpot at bench_exact's calibrated strength
# (e ~ 0.8 at 1 m/s on Hertz), scaled 0.1-1x per impact by `random_impacts`; every peer
# runs it on every family (Hunt-Crossley, alpha U', has no peer on a cap).
LAW = {"law": "linear", "c": 26.75}
# Hunt-Crossley, on Hertz only (no peer runs alpha U' on a cap): the README's law table's
# strength (`bench_exact.LAW_BATCH`, the calibrated 0.373 s/m rounded: e ~ 0.8 at 1 m/s),
# scaled 0.1-1x per impact as `LAW` is. Every peer runs it on Hertz (C = alpha k q^1.5 is a
# row of their damping tables; Sundman N = 2).
HUNT_CROSSLEY = {"law": "hunt-crossley", "alpha": 0.37}
UNIVERSAL = {"law": "universal", "zeta": 0.0}
# The laws of each family's panels, by the family's name in `families` (default: both).
_LAWS_OF = {"Hertz p=1.5": (UNIVERSAL, LAW, HUNT_CROSSLEY)}


def families() -> list[tuple[str, object, float]]:
    """(name, potential, m [kg]): Hertz (the study's), another power (q^2 force) and a
    family that is no power law (the catalogue's sphere)."""
    pot, m = hertz()
    sphere = load_scene("sphere-damped")
    return [
        ("Hertz p=1.5", pot, m),
        ("power p=2", PowerLaw(pot.k, 2.0), m),
        ("sphere (cap)", sphere.potential, sphere.mass),
    ]


def panels() -> list[tuple[str, object, float, dict]]:
    """(family, potential, m [kg], law) of every panel, in the record's order: each family
    of `families` under the universal law and `LAW`, Hertz also under `HUNT_CROSSLEY`."""
    return [
        (family, pot, m, law)
        for family, pot, m in families()
        for law in _LAWS_OF.get(family, (UNIVERSAL, LAW))
    ]


def trades(pot, law) -> bool:
    """Whether ``rtol`` trades anything on the path ours takes (`reference_impl.exact._rtol`):
    a power law's Gauss-Jacobi pairs and the Taylor kernel on sums of powers; a single cap
    under the universal law keeps its fast Gauss-Jacobi pair where its bound is within rtol
    (`reference_impl.exact._one_call`), and under a law of C(q) or Hunt-Crossley runs the
    Taylor kernel with its cap factor (`reference_impl.exact._taylor_cap`). Elsewhere (the
    viscoelastic and zeta laws on a cap: the GBS kernel on its term table) ours runs at full
    accuracy whatever rtol asks, and only that point is timed."""
    if type(pot) is PowerLaw:
        return True
    return isinstance(pot, (Sphere, Ellipsoid)) and law["law"] in _CAP_TAYLOR_LAWS


# The laws a single cap runs on the Taylor kernel (`_taylor_cap`'s docstring), or by its
# Gauss-Jacobi pair (universal); the others stay on the GBS kernel at full accuracy.
_CAP_TAYLOR_LAWS = ("universal", "linear", "power", "polynomial", "hunt-crossley")


def _ours(pot, m, v0, law, rtol, prepared=None):
    """One impact of ours: the universal law by zeta (as users call it), a law by law=."""
    if law["law"] == "universal":
        z = law["zeta"]
        return prepared(v0, z) if prepared is not None else solve(pot, m, v0, z, rtol=rtol)
    return prepared(v0) if prepared is not None else solve(pot, m, v0, law=law, rtol=rtol)


def _bound(sol) -> float:
    """The largest reported relative bound of a solution's times."""
    if hasattr(sol, "quadrature_error"):
        return max(
            sol.quadrature_error / sol.contact_time,
            sol.quadrature_error_zero_force / sol.contact_time_zero_force,
        )
    return sol.error_time / min(sol.contact_time, sol.contact_time_zero_force)


def _errors(rows: np.ndarray, truths: np.ndarray) -> float:
    with np.errstate(divide="ignore", invalid="ignore"):
        err = np.where(truths != 0.0, np.abs(rows / truths - 1.0), np.abs(rows))
    err[np.isnan(err)] = np.inf
    return float(np.max(err)) if err.size else math.nan


def _solver_for(pot, m, law, rtol):
    """The prepared solver of one impact's law (built outside the timing)."""
    if law["law"] == "universal":
        return prepare(pot, m, rtol=rtol)
    return prepare(pot, m, law=law, rtol=rtol)


def panel(family, pot, m, law, impacts: int, blocks: int, mp_subset: int) -> dict:
    """One family and law: ours (one-shot, prepared) and every peer, time against error."""
    name = f"wp {family} {law['law']}"
    drawn = random_impacts(name, law, impacts)  # the universal law's zeta is drawn
    # The proxy truth: ours at full accuracy; impacts it refuses leave the set (counted).
    kept, sols = [], []
    for v0, lw in drawn:
        try:
            sol = _ours(pot, m, v0, lw, None)
        except (UnsupportedError, HCVInputError):
            continue
        # A body that never gets back to q = 0 has no overlap end to compare.
        if math.isfinite(sol.contact_time):
            sols.append(sol)
            kept.append((v0, lw))
    truths = np.array([[float(getattr(s, k)) for k in KEYS] for s in sols])
    proxy = None
    if mp_subset:
        from reference_impl.exact._general_law_mp import solve_law_impact_mp
        from reference_impl.exact.solve import solve_impact_mp

        from ._equal_error import law_bound_ok, universal_bound_ok

        if law["law"] == "universal":
            proxy = check_proxy(
                [(v, lw, s) for (v, lw), s in zip(kept[:mp_subset], sols, strict=False)],
                lambda v, lw: solve_impact_mp(pot, m, v, lw["zeta"], dps=30),
                KEYS,
                universal_bound_ok,
            )
        else:
            try:
                proxy = check_proxy(
                    [(v, lw, s) for (v, lw), s in zip(kept[:mp_subset], sols, strict=False)],
                    lambda v, lw: solve_law_impact_mp(pot, m, v, lw, dps=30),
                    KEYS,
                    law_bound_ok,
                )
            except HCVInputError as exc:  # no 30-digit truth (a viscoelastic or zeta law on a cap)
                proxy = {"impacts": 0, "bounds_held": None, "unchecked_because": str(exc)}
    contestants, curves = {}, {"ours": [], "prepared": []}
    for rtol in OURS_RTOLS if trades(pot, law) else (None,):
        got = [_ours(pot, m, v0, lw, rtol) for v0, lw in kept]
        rows = np.array([[float(getattr(s, k)) for k in KEYS] for s in got])
        point = {
            "rtol": rtol,
            "max_rel_error": _errors(rows, truths),
            "max_rel_bound": max(map(_bound, got)),
        }
        curves["ours"].append(dict(point))
        curves["prepared"].append(dict(point))  # the same numbers, bit for bit (tested)
        preps = [_solver_for(pot, m, lw, rtol) for _, lw in kept]
        contestants[("ours", rtol)] = _one_shot(pot, m, kept, rtol)
        contestants[("prepared", rtol)] = _prepared(kept, preps)
    for peer, case in peer_cases(pot, m).items():
        lad = set_ladder(case, kept, truths, KEYS, 0.0, PEER_RTOLS)
        if lad is None:  # the peer does not run this law
            continue
        calls = [case(v0, lw) for v0, lw in kept]
        curves[peer] = []
        for rung in lad["ladder"]:
            if rung["no_end"] or not math.isfinite(rung["max_rel_error"]):
                continue  # a rung that left an impact without its end is no point
            curves[peer].append({k: rung[k] for k in ("rtol", "max_rel_error", "mean_nfev")})
            contestants[(peer, rung["rtol"])] = _peer_pass(calls, rung["rtol"])
    t = _interleaved(contestants, blocks)
    n = len(kept)
    for who, points in curves.items():
        for p in points:
            p["us"] = t[(who, p["rtol"])] * 1e6 / n
    return {
        "family": family,
        "law": law["law"] if law["law"] == "universal" else dict(law),
        "potential": repr(pot),
        "m": m,
        "impacts": n,
        "left_out": len(drawn) - n,  # refused by ours, or no return to q = 0
        "proxy_check": proxy,
        "curves": curves,
    }


def _one_shot(pot, m, kept, rtol):
    def run_set():
        for v0, lw in kept:
            _ours(pot, m, v0, lw, rtol)

    return run_set


def _prepared(kept, preps):
    def run_set():
        for (v0, lw), p in zip(kept, preps, strict=True):
            _ours(None, None, v0, lw, None, p)

    return run_set


def _peer_pass(calls, rtol):
    def run_set():
        for c in calls:
            c(rtol)

    return run_set


def run(impacts: int = IMPACTS, blocks: int = 5, mp_subset: int = 0) -> dict:
    """Every panel of `panels`; the record of `SCHEMA`."""
    load0 = _load()
    done = []
    for family, pot, m, law in panels():
        done.append(panel(family, pot, m, law, impacts, blocks, mp_subset))
        print(f"  {family}, {done[-1]['law']}: {done[-1]['impacts']} impacts", flush=True)
    return {
        "schema": SCHEMA,
        "keys": list(KEYS),
        "error_floor": ERROR_FLOOR,
        "ours_rtols": list(OURS_RTOLS),
        "peer_rtols": list(PEER_RTOLS),
        "peers": {k: PEER_LABELS[k] for k in PEER_LABELS},
        "blocks": blocks,
        "impacts_drawn": impacts,
        "timing": f"CPU time (process_time) of one pass over the set, {blocks} interleaved "
        "blocks, median, per impact",
        "truth": "ours at full accuracy (proxy); checked against 30 digits on "
        f"{mp_subset} impacts per panel where a 30-digit truth exists (power laws and their "
        "sums, a single cap under a law of C(q) or Hunt-Crossley; elsewhere unchecked, said in "
        "its panel)",
        "panels": done,
        "load_average_1min": load0,
        "load_average_1min_after": _load(),
        "machine": machine_info(),
    }


_STYLE = {
    "ours": ("tab:red", "o", "ours, one-shot solve(..., rtol)"),
    "prepared": ("tab:red", "s", "ours, prepare(..., rtol) call"),
    "dop853": ("tab:blue", "v", "DOP853 (numba)"),
    "dop853_sqrt": ("tab:cyan", "^", "DOP853, q·√q (numba)"),
    "sundman": ("tab:green", "D", "DOP853, Sundman-regularised (numba)"),
    "numbalsoda": ("tab:purple", "x", "numbalsoda dop853, regularised"),
}


def _law_title(law) -> str:
    """A panel's law as its title says it (the record's ``law``: "universal" or a dict)."""
    if law == "universal":
        return "universal law"
    if law["law"] == "hunt-crossley":
        return f"Hunt-Crossley, α = {law['alpha']:g} s/m"
    return f"{law['law']} dashpot"


def figure(record: dict, path) -> None:
    """The log-log figure: one panel per family (columns) and law (rows); a law run on fewer
    families (Hunt-Crossley: Hertz alone) leaves cells empty, and the legend takes them."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = record["panels"]
    fams = list(dict.fromkeys(p["family"] for p in panels))
    laws = list(dict.fromkeys(str(p["law"]) for p in panels))
    fig, axes = plt.subplots(
        len(laws), len(fams), figsize=(4.2 * len(fams), 3.6 * len(laws)), squeeze=False
    )
    floor = record["error_floor"]
    used = set()
    for p in panels:
        cell = (laws.index(str(p["law"])), fams.index(p["family"]))
        used.add(cell)
        ax = axes[cell[0]][cell[1]]
        for who, pts in p["curves"].items():
            if not pts:
                continue
            color, marker, label = _STYLE.get(who, ("k", ".", who))
            x = [max(q["max_rel_error"], floor) for q in pts]
            y = [q["us"] for q in pts]
            ls = "--" if who == "prepared" else "-"
            ax.loglog(x, y, ls, color=color, marker=marker, ms=4, lw=1.2, label=label)
        ax.set_title(f"{p['family']}, {_law_title(p['law'])}", fontsize=9)
        ax.set_xlim(3e-17, 3e-5)
        ax.invert_xaxis()
        ax.grid(True, which="major", alpha=0.3)
        ax.set_xlabel(f"largest relative error, {p['impacts']} impacts")
        ax.set_ylabel("CPU time per impact [µs]")
    handles = {}
    for ax in axes.flat:
        for h, lab in zip(*ax.get_legend_handles_labels(), strict=True):
            handles.setdefault(lab, h)
    empty = [axes[i][j] for i in range(len(laws)) for j in range(len(fams)) if (i, j) not in used]
    for ax in empty:
        ax.axis("off")
    if empty:  # the legend in the first empty cell, one entry a line: no room lost below
        empty[0].legend(handles.values(), handles.keys(), loc="center", fontsize=8)
        bottom = 0.0
    else:
        fig.legend(handles.values(), handles.keys(), loc="lower center", ncol=3, fontsize=8)
        bottom = 0.07
    fig.suptitle(
        "Work-precision: time per impact against achieved error "
        f"(commit {str(record['machine'].get('commit', '?'))[:12]}, "
        f"load {record['load_average_1min']:.1f}; {record['blocks']} timing block(s); "
        f"errors below {floor:.0e}, the proxy truth's resolution, drawn at it)",
        fontsize=10,
    )
    fig.tight_layout(rect=(0, bottom, 1, 0.96))
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--json", help="write the record here (e.g. reports/bench/workprecision.json)")
    ap.add_argument("--png", help="write the figure here (e.g. reports/bench/workprecision.png)")
    ap.add_argument("--impacts", type=int, default=IMPACTS, help="random impacts per panel")
    ap.add_argument("--blocks", type=int, default=5, help="interleaved timing blocks")
    ap.add_argument("--mp-subset", type=int, default=0, help="impacts checked at 30 digits")
    ap.add_argument("--figure-from", help="draw --png from this record instead of running")
    args = ap.parse_args(argv)
    if args.figure_from:
        figure(json.loads(Path(args.figure_from).read_text()), args.png)
        return 0
    record = run(args.impacts, args.blocks, args.mp_subset)
    for p in record["panels"]:
        print(f"{p['family']}, {p['law']}:")
        for who, pts in p["curves"].items():
            cells = ", ".join(f"{q['max_rel_error']:.1e}/{q['us']:.1f}us" for q in pts)
            print(f"  {who}: {cells}")
    if args.json:
        write_json(args.json, record)
    if args.png:
        figure(record, args.png)
    return 0


if __name__ == "__main__":
    sys.exit(main())
