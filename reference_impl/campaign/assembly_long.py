"""The long-horizon record of the assemblies claim: its counted cases at 1e6 steps.

Run:  python -m reference_impl.campaign.assembly_long [--out PATH] [--workers N] [--cases ...]

The claim ``sec6-assemblies`` (`reference_impl.claims.sec6_assemblies`) measures its
ensembles at 1e4 and 1e5 steps in every report run; the issue's third horizon, 1e6 steps,
costs minutes of CPU per case (a 4 x 4 lattice ~4 min), so it is measured here, once, and
kept as a record (``reports/assemblies_1e6.json``, `_assembly_record.RECORD_PATH`) that the
claim reads and merges (`sec6_assemblies.merge_record`). The search is the claim's own:
`search_ensemble` with the claim's `N_LANES`, `GRID` and `CRITERION` on the claim's model
(`case_model`), as `assembly_report` runs it, the ensemble cut into groups of
`LANE_GROUP` lanes (lane k of a group is lane first_lane + k of the ensemble, bit for bit)
that the sweep engine (`reference_impl.sweep.run_cases`, Dask) spreads over ``--workers``
processes. The group holding lane 0 also runs lane 0 at its largest stable step over the
horizon for the claim's cage check (`cage_fraction`).

Cases: the claim's counted ones. The square and honeycomb layers are left out (named in the
record's ``left_out``): touching, unconfined, their bodies leave their cages within ~1e3
steps, so the claim reports them without counting them, and a longer horizon does not
change that. ``--cases`` runs a subset; the other counted cases are then listed in
``left_out`` with the reason given by ``--why``.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

from reference_impl._atomic import atomic_write
from reference_impl._format import jsonable
from reference_impl.assembly.lanes import cage_fraction
from reference_impl.assembly.safe import tangent_step
from reference_impl.assembly.search import Ensemble, reference_step, search_ensemble
from reference_impl.claims import sec6_assemblies as claim
from reference_impl.claims._assembly_record import LONG_HORIZON, RECORD_PATH, SCHEMA, read_record
from reference_impl.errors import HCVInputError
from reference_impl.provenance import machine_info
from reference_impl.stability.criteria import EnergyGrowth
from reference_impl.sweep import run_cases

__all__ = [
    "LANE_GROUP", "LEFT_OUT", "add_to", "check_old", "expected_cases", "long_cases", "main",
    "run_group", "run_record",
]  # fmt: skip

# Lanes per sweep case: 4 cases per ensemble of 32, so that 2 workers share even the
# largest case (a 4 x 4 lattice, minutes) and the last cases to finish are short.
LANE_GROUP = 8
# The claim's cases that are reported but not counted (their bodies leave their cages,
# measured: `sec6_assemblies` module docstring), hence not run here.
LEFT_OUT = {
    "honeycomb 4x4, periodic": "not counted by the claim: its bodies leave their cages "
    "within ~1e3 steps (unconfined touching layer)",
    "square 4x4, periodic": "not counted by the claim: its bodies leave their cages "
    "within ~1e3 steps (unconfined touching layer)",
}


def long_cases() -> list[str]:
    """Labels of the claim's full cases that the record measures (most contacts first)."""
    rows = [(asm.n_contacts * asm.n_bodies, label) for label, _, _, asm in claim.cases()]
    return [label for _, label in sorted(rows, reverse=True) if label not in LEFT_OUT]


def _criterion(horizon: int) -> EnergyGrowth:
    return EnergyGrowth(n_steps=horizon, **claim.CRITERION)


def _assembly(label: str):
    for name, _, _, asm in claim.cases():
        if name == label:
            return asm
    raise HCVInputError(f"unknown case {label!r}: not one of the claim's cases")


def run_group(item: tuple) -> dict:
    """One sweep case: lanes first_lane .. first_lane + n_lanes - 1 of a case's ensemble.

    Parameters
    ----------
    item : tuple
        (case label, first lane, number of lanes, horizon in steps).

    Returns
    -------
    dict
        ``dt_crit``, ``dt_stable`` (s, per lane), ``evidence``, ``q_run`` (m),
        ``contact_updates``, ``criterion``, ``cpu_s`` (this process's CPU time, s), and for
        the group of lane 0 ``cage_fraction`` (lane 0 at its largest stable step).
    """
    label, first, n, horizon = item
    cpu = time.process_time()
    model = claim.case_model(_assembly(label))
    _, _, ref = reference_step(model)
    ens = search_ensemble(
        model, ref, n_lanes=n, criterion=_criterion(horizon), grid=claim.GRID, first_lane=first
    )
    out = {
        "dt_crit": ens.dt_crit.tolist(),
        "dt_stable": ens.dt_stable.tolist(),
        "evidence": list(ens.evidence),
        "q_run": ens.q_run,
        "contact_updates": ens.contact_updates,
        "criterion": ens.criterion,
    }
    if first == 0:
        out["cage_fraction"] = cage_fraction(model, float(ens.dt_stable[0]), horizon)
    out["cpu_s"] = time.process_time() - cpu
    return out


def _items(labels: list[str], horizon: int) -> list[tuple]:
    n = claim.N_LANES
    return [(lab, a, min(LANE_GROUP, n - a), horizon) for lab in labels for a in range(0, n, LANE_GROUP)]  # fmt: skip


def _case_record(label: str, parts: list[dict], horizon: int) -> dict:
    """One case of the record from its groups' results (in lane order)."""
    asm = _assembly(label)
    model = claim.case_model(asm)
    _, safe, _ = reference_step(model)
    ens = Ensemble(
        horizon=horizon,
        dt_crit=np.concatenate([p["dt_crit"] for p in parts]),
        dt_stable=np.concatenate([p["dt_stable"] for p in parts]),
        evidence=[e for p in parts for e in p["evidence"]],
        q_run=max(p["q_run"] for p in parts),
        contact_updates=sum(p["contact_updates"] for p in parts),
        criterion=parts[0]["criterion"],
    )
    qs = ens.quantiles()
    paper = safe["paper"]
    d, z = next((d, z) for name, d, z, _ in claim.cases() if name == label)
    return {
        "case": label,
        "shape": f"{asm.n_bodies} bodies, {asm.n_contacts} contacts, d = {d}, Z = {z:g}",
        "n_bodies": asm.n_bodies,
        "n_contacts": asm.n_contacts,
        "dim": d,
        "coordination": z,
        "dt_safe": safe,
        "horizon": horizon,
        "criterion": ens.criterion,
        # inf (no failure up to the grid's limit) is written "inf": the claim refuses it
        "dt_crit": ens.dt_crit.tolist(),
        "dt_stable": ens.dt_stable.tolist(),
        "evidence": ens.evidence,
        "quantiles": qs,
        "ratio": {p: v / paper for p, v in qs.items()},
        "p_fail": ens.p_fail(),
        "dt_tangent": tangent_step(asm, model.potential, ens.q_run),
        "q_run": ens.q_run,
        "cage_fraction": parts[0]["cage_fraction"],
        "contact_updates": ens.contact_updates,
        "cpu_s": sum(p["cpu_s"] for p in parts),
    }


def _load():
    try:
        return [round(x, 2) for x in os.getloadavg()]
    except OSError:
        return None


def run_record(labels=None, *, workers: int = 2, horizon: int = LONG_HORIZON, why: str = "",
               progress=None) -> dict:  # fmt: skip
    """The record of ``labels`` (default `long_cases`) at ``horizon`` steps (a dict).

    Parameters
    ----------
    labels : list of str, optional
        The claim's case labels to run.
    workers : int
        Local Dask worker processes (`run_cases`); 0 runs here, serially.
    horizon : int
        Steps (the record's claim reads only `LONG_HORIZON`; tests pass it too).
    why : str
        Why the counted cases not in ``labels`` were not run (the record's ``left_out``).
    progress : callable, optional
        ``progress(done, total)`` after each finished group.
    """
    every = long_cases()
    labels = list(every if labels is None else labels)
    for lab in labels:
        if lab not in every:
            raise HCVInputError(
                f"--cases {lab!r}: not one of the counted cases ({', '.join(every)})"
            )
    left = [{"case": c, "why": w} for c, w in LEFT_OUT.items()]
    left += [{"case": c, "why": why or "not run"} for c in every if c not in labels]
    info = machine_info()
    load0, t0 = _load(), time.perf_counter()
    items = _items(labels, horizon)
    outs = run_cases(items, run_group, workers=workers, progress=progress)
    wall = time.perf_counter() - t0
    cases = []
    for lab in labels:
        parts = [o for it, o in zip(items, outs, strict=True) if it[0] == lab]
        cases.append(_case_record(lab, parts, horizon))
    return {
        "schema": SCHEMA,
        "claim": claim.ID,
        "what": "Delta t_crit of the claim's ensembles at the long horizon "
        "(reference_impl.campaign.assembly_long)",
        "date": _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "commit": info["commit"],
        "git_dirty": info["git_dirty"],
        "machine": info,
        "load_average_start": load0,
        "load_average_end": _load(),
        "workers": workers,
        "lane_group": LANE_GROUP,
        "wall_s": wall,
        "cpu_s": sum(c["cpu_s"] for c in cases),
        "horizon": horizon,
        "settings": claim.record_settings(),
        "left_out": left,
        "cases": cases,
    }


def expected_cases() -> dict:
    """The claim's cases as its reader checks a record (shape, Delta t_safe in s)."""
    out = {}
    for label, d, z, asm in claim.cases():
        _, safe, _ = reference_step(claim.case_model(asm))
        out[label] = {"n_bodies": asm.n_bodies, "n_contacts": asm.n_contacts, "dim": d,
                      "coordination": z, "dt_safe": safe["paper"]}  # fmt: skip
    return out


def check_old(path) -> dict:
    """The record at ``path`` as the claim would read it (`HCVInputError` when it would
    ignore it), as its JSON."""
    _, why = read_record(path, claim.record_settings(), expected_cases())
    if why is not None:
        raise HCVInputError(f"--add-to {path}: the claim would ignore it ({why})")
    return json.loads(Path(path).read_text(encoding="utf-8"))


def add_to(old: dict, new: dict) -> dict:
    """The record ``old`` with the cases of the later run ``new`` added (`run_record`'s
    dicts): each added case carries its run's ``commit``, ``date`` and ``git_dirty``, the
    run is listed in ``added`` (commit, date, machine, load, workers, seconds, cases), and
    its cases leave ``left_out``. The first run's provenance stays at the top.

    Raises
    ------
    HCVInputError
        A case of ``new`` already in ``old``, or another horizon or settings.
    """
    have = {c["case"] for c in old["cases"]}
    labels = [c["case"] for c in new["cases"]]
    again = [x for x in labels if x in have]
    if again:
        raise HCVInputError(f"--add-to: {again[0]!r} is already in the record")
    if new["settings"] != old["settings"] or new["horizon"] != old["horizon"]:
        raise HCVInputError("--add-to: the record was measured with other settings or horizon")
    run = {k: new[k] for k in ("commit", "date", "git_dirty")}
    keys = ("machine", "load_average_start", "load_average_end", "workers", "wall_s", "cpu_s")
    return {
        **old,
        "cases": [*old["cases"], *({**c, **run} for c in new["cases"])],
        "left_out": [x for x in old["left_out"] if x["case"] not in labels],
        "added": [*old.get("added", []), {**run, **{k: new[k] for k in keys}, "cases": labels}],
    }


def main(argv=None) -> int:
    """The command line (see the module docstring); returns the exit status."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(RECORD_PATH), help="the record (JSON) to write")
    ap.add_argument("--workers", type=int, default=2, help="Dask worker processes (0: here)")
    ap.add_argument("--cases", nargs="+", metavar="LABEL", help="a subset of the cases")
    ap.add_argument("--why", default="", help="why the other counted cases are not run")
    ap.add_argument("--add-to", metavar="PATH", help="add the cases to this record (a later run)")
    args = ap.parse_args(argv)
    try:
        if args.workers < 0:
            raise HCVInputError(f"--workers must be >= 0, got {args.workers}")
        t0 = time.perf_counter()

        def tick(done: int, total: int) -> None:
            print(f"assemblies at {LONG_HORIZON:,} steps: {done}/{total} lane groups done, "
                  f"{time.perf_counter() - t0:.0f} s", flush=True)  # fmt: skip

        old = check_old(args.add_to) if args.add_to else None
        ran = run_record(args.cases, workers=args.workers, why=args.why, progress=tick)
        rec = ran if old is None else add_to(old, jsonable(ran))
    except HCVInputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    # strict JSON: an infinite value is written "inf" (the claim refuses the record then)
    atomic_write(Path(args.out), json.dumps(jsonable(rec), indent=1, allow_nan=False) + "\n")
    for c in ran["cases"]:
        print(f"{c['case']}: 5/50/95 % of Delta t_crit / Delta t_safe "
              f"{c['ratio']['5']:.4g} / {c['ratio']['50']:.4g} / {c['ratio']['95']:.4g}, "
              f"cage {c['cage_fraction']:.3g}, {c['cpu_s']:.0f} s CPU")  # fmt: skip
    print(f"wrote {args.out} ({ran['cpu_s']:.0f} s CPU, {ran['wall_s']:.0f} s wall, load "
          f"{ran['load_average_start']} -> {ran['load_average_end']})")  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
