"""What one case runs, inside a worker: the task's rows, as plain JSON-ready dicts.

Every task returns one dict per impact speed (per adapter variant and speed for
``bench:ADAPTER``) with the same fields as the task's ``--json`` result:
``hcv dt-crit --json`` (whatever `DtCritResult.to_dict` returns), ``hcv solve
--json``, the per-speed records of ``hcv bench --json`` flattened with dotted
names (plus ``rel_error.*`` relative errors), or one ``hcv calibrate --json`` row. Nested values (a counterexample) become JSON text so the table stays flat;
"inf"/"nan" written as strings by the JSON encoders become floats again.

The per-case time limit is cooperative: `check_deadline` is called between
engine calls (dt-crit), between speeds (solve) and between adapter runs
(bench), and raises `CaseTimeout` past the deadline.
"""

from __future__ import annotations

import json
import math
import threading
import time
from dataclasses import replace

from reference_impl.bench.calibration.calibrate import calibrate, spec_with_options
from reference_impl.bench.scorecard.runner import run_bench
from reference_impl.errors import HCVInputError
from reference_impl.scenes import scene_from_dict
from reference_impl.sweep._assembly import assembly_rows
from reference_impl.tasks import search_loaded_scene, solve_scene

__all__ = ["CaseTimeout", "bench_status", "check_deadline", "deadline", "run_case"]

_local = threading.local()
_NONFINITE = {"inf": math.inf, "-inf": -math.inf, "nan": math.nan}


class CaseTimeout(Exception):
    """A case ran past its time limit."""


class deadline:
    """Context manager: `check_deadline` raises `CaseTimeout` after ``seconds`` (this thread)."""

    def __init__(self, seconds: float | None):
        self.seconds = seconds

    def __enter__(self):
        self._prev = getattr(_local, "deadline", None)
        _local.deadline = (
            None if self.seconds is None else (time.monotonic() + self.seconds, self.seconds)
        )
        return self

    def __exit__(self, *exc):
        _local.deadline = self._prev
        return False


def check_deadline(*_args) -> None:
    """Raise `CaseTimeout` when this thread's case is past its time limit (a progress hook)."""
    d = getattr(_local, "deadline", None)
    if d is not None and time.monotonic() > d[0]:
        raise CaseTimeout(f"timeout after {d[1]:g} s")


def _flat(d: dict, prefix: str = "") -> dict:
    """Nested dicts -> dotted keys; lists and deeper values -> JSON text; 'inf' -> inf."""
    out: dict = {}
    for k, v in d.items():
        name = f"{prefix}{k}"
        if (
            isinstance(v, dict)
            and prefix == ""
            and k in ("measured", "exact", "dt_crit", "sustained")
        ):
            out.update(_flat(v, name + "."))
        elif isinstance(v, (dict, list, tuple)):
            out[name] = json.dumps(v, default=str) if v else None
        elif isinstance(v, str) and v in _NONFINITE:
            out[name] = _NONFINITE[v]
        else:
            out[name] = v
    return out


def _dt_crit_rows(scene, criterion: str | None) -> list[dict]:
    """As ``hcv dt-crit --json``: `search_scene` with the scene's gap, damping, criterion."""

    # An empty criterion text in a spec means the default, as an absent one.
    results = search_loaded_scene(scene, criterion or None, check_deadline)
    return [_flat(r.to_dict()) for r in results]


def _solve_rows(scene) -> list[dict]:
    """As ``hcv solve --json``: one row per speed of `reference_impl.tasks.solve_scene`."""

    rows = []
    for v0 in scene.velocities:
        check_deadline()
        rows.extend(_flat(r) for r in solve_scene(replace(scene, velocities=(v0,))))
    return rows


def bench_status(statuses) -> str:
    """A scorecard's verdict: "fail", "error" (ours), "nothing measured" or "pass"."""
    statuses = list(statuses)
    if "fail" in statuses:
        return "fail"
    if "error" in statuses:
        return "error"
    if "pass" not in statuses:
        return "nothing measured"
    return "pass"


def _errors(speed: dict) -> dict:
    """Relative errors of one speed record: measured against the declared law's exact
    values, and the restitution against the one asked (columns ``rel_error.*``)."""
    meas, ex = speed.get("measured") or {}, speed.get("exact") or {}
    out = {}
    for k in ("restitution", "restitution_zero_force", "contact_time", "max_penetration"):
        got, want = meas.get(k), ex.get(k)
        if isinstance(got, float) and isinstance(want, float) and want:
            out[f"rel_error.{k}"] = abs(got - want) / abs(want)
    asked, got = speed.get("asked_restitution"), meas.get("restitution")
    if isinstance(got, float) and isinstance(asked, float) and asked:
        out["rel_error.restitution_asked"] = abs(got - asked) / asked
    return out


def _bench_rows(scene, adapter: str, code: dict | None = None) -> list[dict]:
    """``hcv bench ADAPTER`` on the case's scene: one row per variant and speed.

    Each row carries the case's scorecard (metric counts, failed metric names,
    status) and the per-speed record of the JSON report, flattened, with the
    relative errors as ``rel_error.*`` columns. ``code`` holds swept adapter options
    (``adapter``) and run settings (``run``: steps_per_contact).
    """

    code = code or {}
    spec = spec_with_options(adapter, code.get("adapter", {}))
    tol = {"run": dict(code["run"])} if code.get("run") else None
    result = run_bench(spec, scenes=[scene], tolerances=tol, progress=check_deadline)
    d = result.to_dict()
    rows = []
    for ctx in d["records"]:
        mine = [m for m in d["metrics"] if m["variant"] == ctx["variant"]]
        head = {
            "variant": ctx["variant"],
            # this variant's verdict (the JSON's top-level status covers all variants), as
            # the gate decides it: a failed metric, then one our reference could not
            # decide, then nothing measured at all, are not a pass
            "status": bench_status([m["status"] for m in mine]),
            "metrics_pass": sum(m["status"] == "pass" for m in mine),
            "metrics_fail": sum(m["status"] == "fail" for m in mine),
            "metrics_error": sum(m["status"] == "error" for m in mine),
            "metrics_skip": sum(m["status"] == "skip" for m in mine),
            "failed_metrics": ",".join(m["metric"] for m in mine if m["status"] == "fail"),
            "convergence_order": ctx["convergence_order"],
            "skipped": ctx["skipped"],
        }
        if ctx["speeds"]:
            rows.extend(_flat({**head, **s}) | _errors(s) for s in ctx["speeds"])
        else:
            rows.append(
                _flat({**head, "v0": scene.velocities[0], "sustained": ctx["sustained"] or {}})
            )
    if result.interrupted:
        raise KeyboardInterrupt
    return rows


def _calibrate_rows(scene, adapter: str, code: dict) -> list[dict]:
    """``hcv calibrate`` on the case's scene: one row (value found, achieved, metrics)."""

    cal = dict(code.get("calibrate", {}))
    spc = cal.pop("steps_per_contact", code.get("run", {}).get("steps_per_contact", 200))
    res = calibrate(
        spec_with_options(adapter, code.get("adapter", {})),
        scene,
        param=cal["param"],
        target=float(cal["target"]),
        end=cal.get("end", "overlap"),
        steps_per_contact=spc,
        v0=cal.get("v0"),
        bracket=cal.get("range"),
        progress=check_deadline,
    )
    d = res.to_dict()
    metrics = d.pop("metrics")
    row = _flat({k: v for k, v in d.items() if k not in ("range", "delivered")})
    row["range_lo"], row["range_hi"] = d["range"]
    row["delivered_min"], row["delivered_max"] = d["delivered"]
    for part, values in metrics.items():
        for k, v in values.items():
            if isinstance(v, (int, float)):
                row[f"{part}.{k}"] = v
    return [row]


def run_case(payload: dict) -> list[dict]:
    """Run one case (a `Case.payload`) and return its rows; exceptions propagate.

    Pure: the result depends on the payload only (its ``key`` hashes it).
    """

    scene = scene_from_dict(payload["scene"], f"case {payload['key']}")
    task = payload["task"]
    with deadline(payload.get("timeout")):
        group = (payload.get("code") or {}).get("assembly")
        if task == "dt-crit" and group is not None:  # a group of lanes of an ensemble
            return assembly_rows(scene, group, check_deadline)
        if task == "dt-crit":
            return _dt_crit_rows(scene, payload.get("criterion"))
        if task == "solve":
            return _solve_rows(scene)
        if task.startswith("bench:"):
            return _bench_rows(scene, task[len("bench:") :], payload.get("code"))
        if task.startswith("calibrate:"):
            return _calibrate_rows(scene, task[len("calibrate:") :], payload.get("code") or {})
    raise HCVInputError(f"unknown task {task!r}")
