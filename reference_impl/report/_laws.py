"""Report section: restitution against impact speed for every damping law (issue 18).

Measured by `reference_impl.studies.laws.laws_results` (calibration e = 0.8 at 1 m/s,
Hertz); every number of the text is read from that measurement in the results dict.
"""

from __future__ import annotations

import math

import numpy as np

from reference_impl.report._blocks import IMG, UL, H, P, T, _num

__all__ = ["laws_figure", "laws_blocks", "FIGURE"]

FIGURE = "damping_laws.png"


def laws_figure(data: dict, path) -> None:
    """One figure: e(v0) of every law at both ends (log speed axis), the legend right of it."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(11.5, 5.0), layout="constrained")
    ax = fig.subplots()
    v = np.asarray(data["speeds"])
    for i, row in enumerate(data["laws"]):
        color = f"C{i}"
        ax.semilogx(v, row["overlap"], "-", color=color, label=f"{row['law']} (end q = 0)")
        ax.semilogx(
            v,
            row["zero_force"],
            "--",
            color=color,
            lw=1.0,
            label=f"{row['law']} (end U' + C q' = 0)",
        )
    sp = data["schwager_poeschel"]
    ax.semilogx(
        v,
        [1 - r["one_minus_e_expansion"] for r in sp],
        ":",
        color="k",
        label="Schwager & Pöschel, 2 terms (viscoelastic)",
    )
    ax.axvline(data["v_cal"], color="0.6", lw=0.8)
    ax.set_xlabel("impact speed v0 [m/s]")
    ax.set_ylabel("coefficient of restitution e = -v_out / v0 [-]")
    ax.set_title(
        f"Hertz contact, each law calibrated to e = {data['e_cal']} at {data['v_cal']} m/s"
    )
    ax.set_ylim(0, 1.02)
    # Off the data: right of the axes.
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0)
    ax.grid(True, which="both", alpha=0.3)
    fig.savefig(path, dpi=130)


def _pct(x) -> str:
    return f"{100 * x:.2g} %"


def laws_blocks(r) -> list:
    d = r.get("damping_laws")
    if not d:
        return []
    v = d["speeds"]
    rows, bullets = [], []
    for row in d["laws"]:
        rows.append(
            [
                row["law"],
                ", ".join(
                    f"{k} = "
                    + (
                        _num(x, 6)
                        if not isinstance(x, list)
                        else "[" + ", ".join(_num(y, 6) for y in x) + "]"
                    )
                    for k, x in row["damping"].items()
                    if k != "law"
                ),
                _num(row["overlap_at_vmin"], 4),
                _num(row["overlap_at_vmax"], 4),
                _num(row["overlap_spread"], 3),
                _num(row["zero_force_at_vmin"], 4),
                _num(row["zero_force_at_vmax"], 4),
                _num(row["zero_force_spread"], 3),
                "all"
                if all(row["returns"])
                else f"{sum(not x for x in row['returns'])} speeds do not",
            ]
        )
        if row["law"] == "universal":
            bullets.append(
                f"universal: flat, spread {row['overlap_spread']:.1e} (end q = 0) and "
                f"{row['zero_force_spread']:.1e} (zero-force end) over {v[0]:g}–{v[-1]:g} m/s."
            )
        else:
            bullets.append(
                f"{row['law']}: e goes from {row['overlap_at_vmin']:.3f} at {v[0]:g} m/s to "
                f"{row['overlap_at_vmax']:.3f} at {v[-1]:g} m/s (end q = 0; spread "
                f"{row['overlap_spread']:.3f}); zero-force end {row['zero_force_at_vmin']:.3f} to "
                f"{row['zero_force_at_vmax']:.3f}."
            )
    sp = d["schwager_poeschel"]
    lo, mid, hi = sp[0], min(sp, key=lambda x: abs(math.log10(x["v0"]))), sp[-1]
    sp_text = (
        "Viscoelastic law against the two-term expansion of Schwager & Pöschel, "
        "1 − e ≈ C1 β v0^(1/5) − C2 β² v0^(2/5) with β = (3/2) A (k/m)^(2/5), "
        "C1 = Γ(3/5)√π / (2^(1/5) 5^(2/5) Γ(21/10)) = 1.1534, C2 = (3/5) C1²: the expansion's "
        f"1 − e differs from the measured one by {_pct(lo['rel_dev_overlap'])} (end q = 0) and "
        f"{_pct(lo['rel_dev_zero_force'])} (zero-force end) at {lo['v0']:g} m/s, "
        f"{_pct(mid['rel_dev_overlap'])} and {_pct(mid['rel_dev_zero_force'])} at {mid['v0']:g} m/s, "
        f"{_pct(hi['rel_dev_overlap'])} and {_pct(hi['rel_dev_zero_force'])} at {hi['v0']:g} m/s: "
        "it holds where β v0^(1/5) is small, and the truncated series drifts away as it grows."
    )
    return [
        H(2, "Damping laws: restitution against impact speed (Theorem 3)", "laws"),
        P(
            f"Hertz contact (U' = k q^{d['hertz_p']}, k = {d['hertz_k']:.4g} N/m^1.5, reduced mass "
            f"{d['mass']:.4g} kg) with each damping law of `reference_impl.theory.laws`, its strength "
            f"calibrated so that e = {d['e_cal']} at {d['v_cal']} m/s at the end q = 0, solved at "
            f"{len(v)} speeds from {v[0]:g} to {v[-1]:g} m/s (universal law: exact quadrature; the "
            "others: `reference_impl.exact.general_law`, checked against a 30-digit truth by the suite). "
            "Theorem 3 says only the universal law keeps e independent of speed; measured:"
        ),
        UL_(bullets),
        T(
            [
                "law",
                "parameters (SI)",
                f"e at {v[0]:g} m/s",
                f"e at {v[-1]:g} m/s",
                "spread",
                f"e_F=0 at {v[0]:g}",
                f"e_F=0 at {v[-1]:g}",
                "spread (F = 0)",
                "returns to q = 0",
            ],
            rows,
        ),
        P(sp_text),
        IMG(
            FIGURE,
            "Restitution against impact speed, each law calibrated to e = 0.8 at 1 m/s; "
            "solid: end at q = 0, dashed: end at zero total force; dotted: Schwager & Pöschel's "
            "two-term expansion for the viscoelastic law.",
        ),
    ]


def UL_(items):
    return UL(items)
