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
round-off and left out). One figure per code.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from reference_impl.adapters.base import AdapterScene, ImplementedLaw
from reference_impl.bench.measure import exact_reference, measure
from reference_impl.bench.worker import make_executor
from reference_impl.exact.solve import solve_impact
from reference_impl.report._blocks import IMG, H, P, T
from reference_impl.scenes import load_scene

__all__ = ["FIT_FROM", "SCENES", "STEPS", "resolution_blocks", "resolution_study"]

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


def _plot(code: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scenes = [n for n in SCENES if any(v.get("rows") and v["scene"] == n for v in code["variants"])]
    fig, axes = plt.subplots(len(scenes), 2, figsize=(11, 4.0 * len(scenes)), squeeze=False)
    n = np.array([STEPS[0], STEPS[-1]], float)
    for (a, b), name in zip(axes, scenes, strict=True):
        asked = None
        for var in code["variants"]:
            rows = [r for r in var.get("rows", []) if "restitution" in r]
            if var["scene"] != name or not rows:
                continue
            asked = var["asked_restitution"]
            ns = [r["steps_per_contact"] for r in rows]
            (line,) = a.plot(ns, [r["restitution"] for r in rows], "o-", ms=3, label=var["label"])
            a.plot(ns, [r["exact_restitution"] for r in rows], ":", color=line.get_color(), lw=1)
            ok = [r for r in rows if r.get("err_contact_time", 0) > 0]
            b.loglog([r["steps_per_contact"] for r in ok], [r["err_contact_time"] for r in ok],
                     "o-", ms=3, color=line.get_color(), label=var["label"])  # fmt: skip
        if asked is not None:
            a.axhline(asked, color="k", ls="--", lw=1, label="asked (q = 0 end)")
        for order, style in ((1, "--"), (2, "-.")):
            b.loglog(n, 0.3 * (n / n[0]) ** -order, style, color="grey", lw=0.8,
                     label=f"slope -{order}")  # fmt: skip
        a.set_xscale("log")
        for ax in (a, b):
            ax.set_xlabel("steps per contact N (dt = t_c / N)")
            ax.legend(fontsize=6)
        a.set_ylabel("delivered restitution -v/v0 at q = 0")
        a.set_title(f"{name}: restitution (dotted: exact, declared law)", fontsize=10)
        b.set_ylabel("|contact time / exact - 1| (declared law)")
        b.set_title(f"{name}: contact-time error", fontsize=10)
    fig.suptitle(f"{code['adapter']} at v0 = {code['v0']:g} m/s")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def resolution_study(adapters, fig_dir: Path) -> list[dict]:
    """Measure and plot every code of ``adapters``; returns one JSON-ready dict per code."""
    out = []
    for spec in adapters:
        code = _one_code(spec)
        safe = "".join(ch if ch.isalnum() or ch in "-_" else "_" for ch in str(spec))[:60]
        if any(v.get("rows") for v in code["variants"]):
            code["figure"] = f"steps_{safe}.png"
            _plot(code, fig_dir / code["figure"])
        out.append(code)
    return out


def _g(x, fmt="{:.3g}") -> str:
    return fmt.format(x) if isinstance(x, (int, float)) and math.isfinite(x) else "-"


def resolution_blocks(r: dict) -> list:
    """The section's blocks (headline orders, per-code table, figure)."""
    codes = r.get("steps_per_contact") or []
    if not codes:
        return []
    blocks = [
        H(3, "Delivered restitution and contact time against steps per contact", "steps"),
        P(
            f"Scenes {', '.join(SCENES)} at v0 = {V0:g} m/s, dt = t_c / N for N = "
            f"{', '.join(map(str, STEPS))} (t_c: exact contact time of the scene as asked). "
            "Errors are relative to the exact solution of the law each variant declares at "
            f"that dt; the order is the slope of log(error) against log(dt) for N >= "
            f"{FIT_FROM}; e is the restitution at q = 0 (asked: the scene's, at that end). "
            "A variant clipping tension delivers the zero-force end of its law."
        ),
    ]
    header = ["variant", "scene", "e asked", "order (restitution)", "order (contact time)",
              "e at N = 3", "e at N = 10", "e at N = 200", "e exact (declared, N = 200)",
              "contact-time error at N = 10", "at N = 200", "note"]  # fmt: skip
    for code in codes:
        rows = []
        for var in code["variants"]:
            if "skipped" in var:
                continue  # skipped scenes are listed below the table
            by = {x["steps_per_contact"]: x for x in var["rows"]}
            fails = [f"N = {n}: {x['failure']}" for n, x in by.items() if "failure" in x]
            rows.append(
                [
                    var["label"],
                    var["scene"],
                    _g(var["asked_restitution"], "{:.4g}"),
                    _g(var["order_restitution"], "{:.2f}"),
                    _g(var["order_contact_time"], "{:.2f}"),
                    _g(by.get(3, {}).get("restitution"), "{:.4f}"),
                    _g(by.get(10, {}).get("restitution"), "{:.4f}"),
                    _g(by.get(200, {}).get("restitution"), "{:.4f}"),
                    _g(by.get(200, {}).get("exact_restitution"), "{:.4f}"),
                    _g(by.get(10, {}).get("err_contact_time"), "{:.2g}"),
                    _g(by.get(200, {}).get("err_contact_time"), "{:.2g}"),
                    "; ".join(fails[:2]),
                ]
            )
        blocks += [H(4, code["adapter"]), T(header, rows)]
        skipped = [f"{v['label']} on {v['scene']}: {v['skipped']}"
                   for v in code["variants"] if "skipped" in v]  # fmt: skip
        if skipped:
            blocks.append(P("Not run: " + "; ".join(skipped) + "."))
        if code.get("figure"):
            blocks.append(
                IMG(
                    code["figure"],
                    f"{code['adapter']}: delivered restitution (left; dotted: exact value "
                    "of the declared law; dashed: asked) and contact-time error (right) "
                    "against steps per contact.",
                )
            )
    return blocks
