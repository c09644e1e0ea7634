"""The hard cases' figure: errors across speeds and depths, and the bound near 2a.

Drawn from the rows of `reference_impl.studies.hardcases` as written to results.json
(``hard_cases``); nothing here runs a solver.
"""

from __future__ import annotations

import math

import numpy as np

from reference_impl.report._common import g

__all__ = ["sweeps_figure"]


def sweeps_figure(sweeps: dict, path, u_star: float, settings: dict) -> None:
    """Errors against v0 and q_max/a; the bound, its shortcut and Δt_rec.

    Parameters
    ----------
    sweeps : dict
        ``hard_cases.sweeps`` of results.json (rows of the speed and depth sweeps).
    path : path-like
        PNG written.
    u_star : float
        End of the stiffening domain, q / a (section 10).
    settings : dict
        ``hard_cases.settings`` of results.json: ``ode_rtol``, ``verlet_steps``.
    """
    from matplotlib.figure import Figure

    fig = Figure(figsize=(13.0, 5.8), dpi=110)
    pa, pb, pc = fig.subplots(1, 3)
    # Room below the panels for the one legend of all three (off the data).
    fig.subplots_adjust(left=0.06, right=0.99, bottom=0.27, top=0.88, wspace=0.28)
    floor = 1e-17

    def err_lines(ax, rows, x):
        for key, lab, st in (
            ("exact_err_t_c", "exact solver: t_c", "k*-"),
            ("exact_quadrature_estimate", "exact solver: own error estimate", "k:"),
            ("ode_err_t_c", f"DOP853 rtol {g(settings['ode_rtol'])}: t_c", "o-"),
            ("verlet_err_t_c", f"Verlet {settings['verlet_steps']} steps/contact: t_c", "^-"),
        ):
            y = np.array([r.get(key, math.nan) for r in rows], dtype=float)
            ax.loglog(x, np.maximum(y, floor), st, label=lab, ms=5)
        ax.set_ylabel(f"relative error [-] (vs {settings['mp_dps']}-digit mpmath)")
        ax.grid(True, alpha=0.3)

    sp = sweeps["speed"]
    err_lines(pa, sp, np.array([r["v0"] for r in sp]))
    pa.set(xlabel="impact speed v0 [m/s]", title="(a) Hertz k = 1e9, m = 4.1 g: v0 over 9 decades")
    dp = sweeps["depth"]
    x = np.array([r["q_max_over_a"] for r in dp])
    err_lines(pb, dp, x)
    pb.set_xscale("linear")
    pb.axvline(u_star, color="0.4", ls="--", lw=1)
    pb.text(
        u_star + 0.02, 0.02, f"{u_star:.4f} a", transform=pb.get_xaxis_transform(), fontsize=8.5
    )
    pb.set(
        xlabel="maximum penetration q_max / a [-]",
        xlim=(0, 2.05),
        title="(b) paper ellipsoid: depth up to 2a",
    )
    for r in dp:
        if "dtcrit_over_rec" in r:
            r["_rec_over_safe"] = r["dtcrit_over_safe"] / r["dtcrit_over_rec"]
    for key, lab, st in (
        ("dtcrit_over_safe", "measured Δt_crit/Δt_safe (impact)", "o-"),
        ("shortcut_over_safe", "shortcut 2mv0/U'(q_max) / Δt_safe", "s--"),
        ("_rec_over_safe", "recommended Δt_rec/Δt_safe (impact)", "d:"),
    ):
        y = np.array([r.get(key, math.nan) for r in dp], dtype=float)
        pc.semilogy(x, y, st, label=lab, ms=5)
    for r in dp:
        r.pop("_rec_over_safe", None)
    pc.axhline(1.0, color="k", lw=1.4)
    pc.axvline(u_star, color="0.4", ls="--", lw=1)
    pc.text(
        u_star + 0.02, 0.02, f"{u_star:.4f} a", transform=pc.get_xaxis_transform(), fontsize=8.5
    )
    pc.set(
        xlabel="maximum penetration q_max / a [-]",
        ylabel="step / Δt_safe [-]",
        xlim=(0, 2.05),
        title="(c) ellipsoid: bound, shortcut, Δt_rec",
    )
    handles, labels = pa.get_legend_handles_labels()
    more = pc.get_legend_handles_labels()
    fig.legend(
        handles + more[0],
        labels + more[1],
        fontsize=9,
        loc="lower center",
        bbox_to_anchor=(0.5, 0.0),
        ncol=4,
        frameon=False,
    )
    pc.grid(True, alpha=0.3, which="both")
    fig.suptitle(
        "Hard cases: accuracy and the section 6 bound across scales "
        f"(errors below {g(floor)} drawn at {g(floor)})",
        fontsize=11.5,
    )
    fig.savefig(path)
