"""Report section: what each benchmarked code delivers against steps per contact.

Rendered from the study's rows (results.json ``steps_per_contact``, measured by
`reference_impl.campaign._steps`) and its settings (``steps_per_contact_settings``).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from reference_impl.report._blocks import IMG, H, P, T

__all__ = ["plot_steps", "resolution_blocks"]


def plot_steps(code: dict, path: Path, scenes) -> None:
    """One code's figure: delivered restitution (left) and contact-time error (right)
    against steps per contact, one row per scene of ``scenes`` it ran; each row's legend
    (variants, the asked value, the slope guides) stands right of its panels, off the data."""
    from matplotlib.figure import Figure

    scenes = [n for n in scenes if any(v.get("rows") and v["scene"] == n for v in code["variants"])]
    ns_all = [r["steps_per_contact"] for v in code["variants"] for r in v.get("rows", [])]
    n = np.array([min(ns_all), max(ns_all)], float)
    fig = Figure(figsize=(14.0, 4.2 * len(scenes) + 0.4), layout="constrained")
    axes = fig.subplots(len(scenes), 2, squeeze=False)
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
                     "o-", ms=3, color=line.get_color())  # fmt: skip
        if asked is not None:
            a.axhline(asked, color="k", ls="--", lw=1, label="asked (q = 0 end)")
        for order, style in ((1, "--"), (2, "-.")):
            b.loglog(n, 0.3 * (n / n[0]) ** -order, style, color="grey", lw=0.8,
                     label=f"slope -{order}")  # fmt: skip
        a.set_xscale("log")
        for ax in (a, b):
            ax.set_xlabel("steps per contact N = t_c / dt [-]")
            ax.grid(True, which="major", alpha=0.3)
        handles, labels = [], []
        for ax in (a, b):
            for h, lab in zip(*ax.get_legend_handles_labels(), strict=True):
                handles.append(h)
                labels.append(lab)
        b.legend(handles, labels, fontsize=8.5, loc="upper left", bbox_to_anchor=(1.02, 1.0),
                 borderaxespad=0.0)  # fmt: skip
        a.set_ylabel("delivered restitution -v/v0 at q = 0 [-]")
        a.set_title(f"{name}: restitution (dotted: exact, declared law)", fontsize=10)
        b.set_ylabel("|contact time / exact - 1| (declared law) [-]")
        b.set_title(f"{name}: contact-time error", fontsize=10)
    fig.suptitle(f"{code['adapter']} at v0 = {code['v0']:g} m/s")
    fig.savefig(path, dpi=100)


def _g(x, fmt="{:.3g}") -> str:
    return fmt.format(x) if isinstance(x, (int, float)) and math.isfinite(x) else "-"


def resolution_blocks(r: dict) -> list:
    """The section's blocks (headline orders, per-code table, figure)."""
    codes = r.get("steps_per_contact") or []
    if not codes:
        return []
    st = r["steps_per_contact_settings"]
    blocks = [
        H(3, "Delivered restitution and contact time against steps per contact", "steps"),
        P(
            f"Scenes {', '.join(st['scenes'])} at v0 = {st['v0']:g} m/s, dt = t_c / N for N = "
            f"{', '.join(map(str, st['steps']))} (t_c: exact contact time of the scene as asked). "
            "Errors are relative to the exact solution of the law each variant declares at "
            f"that dt; the order is the slope of log(error) against log(dt) for N >= "
            f"{st['fit_from']}; e is the restitution at q = 0 (asked: the scene's, at that end). "
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
