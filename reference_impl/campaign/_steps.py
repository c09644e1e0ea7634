"""Report section: what each benchmarked code delivers against steps per contact.

For every code given with ``hcv report --adapter`` and each of its variants, on
the linear scene ``hooke-damped`` (the one law LAMMPS, Kratos and MuJoCo all
have: U' = k q, constant dashpot, asked e = 0.5 at the q = 0 end) and on
``hertz-damped`` (Tsuji-type damping, a force that is continuous at contact
onset; MuJoCo declines it), one impact at v0 = 1 m/s is run at dt = t_c / N for N
in `STEPS` (t_c the exact contact time of the scene as asked), through the same
isolated executor as ``hcv bench``. Measured:
the delivered restitution (q = 0 end, -v / v0 at the first sample out of contact)
and the contact time; each is compared with the exact solution of the law the
code declares at that dt (`ImplementedLaw`, which may change with dt: MuJoCo's
timeconst clamp). The order of convergence is the slope of log(error) against
log(dt) over N >= `FIT_FROM` (the asymptotic range; errors below `_FLOOR` are
round-off and left out). One figure per code (drawn by `reference_impl.report._steps`).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from reference_impl.adapters.base import AdapterScene, ImplementedLaw
from reference_impl.bench.measure import exact_reference, measure
from reference_impl.bench.worker import make_executor
from reference_impl.exact.solve import solve_impact
from reference_impl.report._steps import plot_steps
from reference_impl.scenes import load_scene

__all__ = ["FIT_FROM", "SCENES", "STEPS", "V0", "resolution_study", "settings"]

SCENES = ("hooke-damped", "hertz-damped")
V0 = 1.0  # m/s, the scene's middle speed
STEPS = (3, 5, 10, 20, 50, 100, 200, 400, 800)
# The order is fitted where the leading error term dominates: from 20 steps per contact
# on (below, the step is a sizeable fraction of the contact and higher terms matter).
FIT_FROM = 20
# Relative errors below this are round-off, not discretisation (left out of the fit).
_FLOOR = 1e-13
_BUDGET, _EXTRA_STEPS = 4.0, 64


def _order(ns, errs) -> float | None:
    pts = [
        (1.0 / n, e)
        for n, e in zip(ns, errs, strict=True)
        if n >= FIT_FROM and isinstance(e, float) and math.isfinite(e) and e > _FLOOR
    ]
    if len(pts) < 3:
        return None
    x, y = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
    return float(np.polyfit(x, y, 1)[0])


def _one_code(spec: str, timeout: float = 120.0) -> dict:
    """Every variant of ``spec`` on every scene of `SCENES` it runs, at every N of `STEPS`."""
    executor = make_executor(spec)
    out: dict = {"adapter": spec, "v0": V0, "variants": []}
    try:
        for name in SCENES:
            sc = load_scene(name)
            t_c = float(solve_impact(sc.potential, sc.mass, V0, sc.zeta or 0.0).contact_time)
            for i, var in enumerate(executor.variants):
                probe = AdapterScene.from_scene(sc, V0, t_c / 200, 1)
                entry: dict = {"label": var.label, "scene": name,
                               "asked_restitution": probe.restitution}  # fmt: skip
                reason = var.supports(probe)
                if reason:
                    out["variants"].append({**entry, "skipped": reason})
                    continue
                rows = []
                for n in STEPS:
                    dt = t_c / n
                    budget = int(math.ceil(_BUDGET * n)) + _EXTRA_STEPS
                    asc = AdapterScene.from_scene(sc, V0, dt, budget)
                    row: dict = {"steps_per_contact": n, "dt": dt}
                    run = executor.call(i, "impact", asc, timeout=timeout)
                    law = executor.call(i, "implemented_law", asc, timeout=timeout)
                    if run.declined:
                        row["failure"] = f"declined: {run.declined}"
                    elif not run.ok or not law.ok or not isinstance(law.value, ImplementedLaw):
                        row["failure"] = run.error or law.error or "no implemented law"
                    else:
                        m = measure(run.value, V0)
                        ex = exact_reference(law.value, V0)
                        row["restitution"] = m.get("restitution", math.nan)
                        row["contact_time"] = m.get("contact_time", math.nan)
                        row["exact_restitution"] = ex["restitution"]
                        row["exact_contact_time"] = ex["contact_time"]
                        if not m.get("separated"):
                            row["failure"] = m.get("reason", "did not separate")
                        else:
                            row["err_restitution"] = abs(row["restitution"] / ex["restitution"] - 1)
                            row["err_contact_time"] = abs(
                                row["contact_time"] / ex["contact_time"] - 1
                            )
                    rows.append(row)
                ns = [r["steps_per_contact"] for r in rows]
                entry.update(
                    rows=rows,
                    order_restitution=_order(ns, [r.get("err_restitution") for r in rows]),
                    order_contact_time=_order(ns, [r.get("err_contact_time") for r in rows]),
                )
                out["variants"].append(entry)
    finally:
        executor.close()
    return out


def settings() -> dict:
    """What the study ran (results.json ``steps_per_contact_settings``; the report's text)."""
    return {"scenes": list(SCENES), "v0": V0, "steps": list(STEPS), "fit_from": FIT_FROM}


def resolution_study(adapters, fig_dir: Path) -> list[dict]:
    """Measure and plot every code of ``adapters``; returns one JSON-ready dict per code."""
    out = []
    for spec in adapters:
        code = _one_code(spec)
        safe = "".join(ch if ch.isalnum() or ch in "-_" else "_" for ch in str(spec))[:60]
        if any(v.get("rows") for v in code["variants"]):
            code["figure"] = f"steps_{safe}.png"
            plot_steps(code, fig_dir / code["figure"], SCENES)
        out.append(code)
    return out
