"""Fig. 1 of the paper regenerated from the runs of the claim module `reference_impl.claims.fig1`."""

from __future__ import annotations

import numpy as np

from reference_impl.report._common import g

__all__ = ["fig1_figure"]

# MATLAB's default colour order, as in the paper's figure: blue, red, yellow.
COLOURS = ("#0072BD", "#D95319", "#EDB120")


def fig1_figure(runs: list[dict], path, paper: dict, rtol: float) -> None:
    """Panels (a) physical phase space, (b) transformed phase space, (c) time series, (d) drift.

    Parameters
    ----------
    runs : list of dict
        `claims.fig1.runs()`: one run per speed and C0, with its curves.
    path : path-like
        PNG written.
    paper : dict
        The paper's Fig. 1 settings (`studies.paper.FIG1`: velocities, K, M, C0, claimed
        energy error).
    rtol : float
        RK45's relative tolerance of the runs (the panel (d) title).
    """
    FIG1, RTOL = paper, rtol  # noqa: N806 (the paper's names)
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    fig = Figure(figsize=(11.5, 8.6), dpi=110)
    ax = fig.subplots(2, 2)
    # Room above the panels for the line legend and below for the drift legend (off the data).
    fig.subplots_adjust(left=0.075, right=0.985, bottom=0.13, top=0.87, wspace=0.22, hspace=0.3)
    (pa, pb), (pc, pd) = ax
    speeds = list(FIG1["velocities"])
    for r in runs:
        c = COLOURS[speeds.index(r["v0"])]
        ls = "--" if r["C0"] == 0 else "-"
        cu = r["curve"]
        pa.plot(cu["q"] * 1e3, cu["v"], ls, color=c, lw=1.6)
        pb.plot(cu["x"], cu["xp"], ls, color=c, lw=1.6)
        pc.plot(cu["t"] * 1e3, cu["q"] * 1e3, ls, color=c, lw=1.6)
        if r["C0"] == 0:
            pd.semilogy(
                r["t_drift"] * 1e3,
                np.maximum(np.abs(r["rel_H"]), 1e-17),
                ".-",
                color=c,
                lw=0.8,
                ms=2.5,
                label=f"v0 = {r['v0']:.2f} m/s: max {g(r['drift'], 2)}",
            )
    pa.set(
        xlabel="penetration δ [mm]", ylabel="velocity dδ/dt [m/s]", title="(a) physical phase space"
    )
    pb.set(
        xlabel=f"x = √(2U/K) [m]   (K = {FIG1['K']:g} N/m)",
        ylabel=f"x' = dx/dτ [m/s]   (M = {FIG1['M']:g} kg)",
        title="(b) transformed phase space (x, x')",
    )
    pb.set_xlim(left=-0.02 * max(r["curve"]["x"].max() for r in runs))
    pc.set(xlabel="time t [ms]", ylabel="penetration δ [mm]", title="(c) time series")
    claimed = FIG1["claimed_energy_error"]
    pd.axhline(claimed, color="k", lw=1.2, ls=":")
    pd.text(
        0.02,
        claimed * 1.25,
        f"paper: relative error < {g(claimed)}",
        transform=pd.get_yaxis_transform(),
        fontsize=9,
    )
    pd.set(
        xlabel="time t [ms]",
        ylabel="|H(t)/H(0) − 1| [-]",
        title=f"(d) transformed energy drift, C0 = 0, RK45 rtol = atol = {g(RTOL)}",
        ylim=(1e-17, 1e-11),
    )
    fig.legend(
        *pd.get_legend_handles_labels(),
        fontsize=8.5,
        loc="lower right",
        bbox_to_anchor=(0.985, 0.0),
        ncol=3,
        title="(d) C0 = 0",
        title_fontsize=8.5,
        frameon=False,
    )
    for a in ax.flat:
        a.grid(True, alpha=0.3)
        a.tick_params(labelsize=9)
    handles = [
        Line2D([], [], color=c, lw=2, label=f"v0 = {v:.2f} m/s")
        for c, v in zip(COLOURS, speeds, strict=True)
    ]
    handles += [
        Line2D([], [], color="k", ls="--", label="C0 = 0 (conservative)"),
        Line2D([], [], color="k", ls="-", label=f"C0 = {FIG1['C0'][1]:g} (universal law)"),
    ]
    fig.legend(
        handles=handles,
        fontsize=9,
        loc="upper center",
        bbox_to_anchor=(0.5, 0.945),
        ncol=len(handles),
        frameon=False,
    )
    fig.suptitle(
        "Fig. 1 regenerated: ellipsoid a = 15 mm, b = c = 8 mm, m = 0.05 kg, Kn = 1e8, α = 0.5",
        fontsize=12,
    )
    fig.savefig(path)
