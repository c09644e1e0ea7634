"""Several codes' scorecards side by side, and the speed-against-error plot (``hcv report``).

* `side_by_side` / `side_by_side_markdown`: one table with a row per (scene,
  metric) and a column per adapter variant, from the JSON documents of
  `reference_impl.bench.scorecard._json.result_to_dict` (e.g. LAMMPS and Kratos).
* `plot_speed_error`: error against wall time per impact (needs matplotlib).

Both are re-exported by `reference_impl.bench.scorecard.report`.
"""

from __future__ import annotations

from pathlib import Path

from reference_impl.bench.scorecard._cells import _PLAIN_STATUS, _UNITS, _fmt_v
from reference_impl.bench.scorecard._textbook import worst_table_error

__all__ = ["plot_speed_error", "side_by_side", "side_by_side_markdown"]


def side_by_side(docs) -> tuple[list[str], list[list[str]]]:
    """Several codes' scorecards as one table: a row per (scene, metric), a column per variant.

    Parameters
    ----------
    docs : sequence of dict
        JSON documents of `result_to_dict` (one per ``hcv bench`` run, e.g. lammps
        and kratos).

    Returns
    -------
    header, rows : list of str, list of list of str
        ``header`` = ["scene", "metric", "reference", variant...]; a cell is the
        measured value with "pass" / "FAIL", "-" when the variant did not run that
        scene (skipped). ``reference`` is the asked value where it is the same for
        every code (restitution_asked), else empty (each code's own exact law).
    """
    variants: list[str] = []
    cells: dict[tuple[str, str], dict[str, str]] = {}
    refs: dict[tuple[str, str], set] = {}
    for doc in docs:
        for m in doc.get("metrics", []):
            v = m.get("variant", "")
            if v not in variants:
                variants.append(v)
            if m.get("status") in ("skip", "n/a"):
                continue
            key = (m.get("scene", ""), m.get("metric", ""))
            measured = m.get("measured", m.get("value"))
            unit = _UNITS.get(key[1], "")
            status = _PLAIN_STATUS.get(m.get("status"), m.get("status"))
            cells.setdefault(key, {})[v] = f"{_fmt_v(json_number(measured), unit)} {status}".strip()
            if key[1] == "restitution_asked" and m.get("expected") is not None:
                refs.setdefault(key, set()).add(_fmt_v(json_number(m["expected"])))
    header = ["scene", "metric", "reference", *variants]
    rows = []
    for (scene, metric), by in cells.items():
        ref = refs.get((scene, metric), set())
        rows.append(
            [
                scene,
                metric,
                next(iter(ref)) if len(ref) == 1 else "",
                *(by.get(v, "-") for v in variants),
            ]
        )
    return header, rows


def side_by_side_markdown(docs) -> str:
    """`side_by_side` as a markdown table."""
    header, rows = side_by_side(docs)
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(out) + "\n"


def json_number(x):
    """A JSON number back as a float ("inf"/"nan" strings included), else unchanged."""
    if isinstance(x, str) and x in ("inf", "-inf", "nan"):
        return float(x)
    return float(x) if isinstance(x, int) and not isinstance(x, bool) else x


def plot_speed_error(rows, path) -> Path:
    """Error against wall time per impact, one panel per scene, one line per adapter (log-log).

    The exact solver's time for each scene is a dotted vertical line. One legend for all
    panels, below them (off the data, at 8.5 pt). Needs matplotlib.
    """
    from matplotlib.figure import Figure

    scenes = list(dict.fromkeys(r["scene"] for r in rows)) or ["(no rows)"]
    fig = Figure(figsize=(4.2 * len(scenes), 5.0), layout="constrained")
    axes = fig.subplots(1, len(scenes), sharey=True, squeeze=False)
    for ax, scene in zip(axes[0], scenes, strict=True):
        groups: dict[str, list] = {}
        for r in rows:
            if r["scene"] != scene:
                continue
            if r.get("steps_per_contact") is None:
                ax.axvline(r["seconds"], color="grey", lw=0.6, ls=":")
            elif not r.get("failure"):
                groups.setdefault(r["adapter"], []).append(r)
        for adapter, rs in groups.items():
            rs = sorted(rs, key=lambda r: r["dt"], reverse=True)
            err = [
                worst_table_error(
                    {
                        k: r[k]
                        for k in ("err_restitution", "err_contact_time", "err_max_penetration")
                    }
                )
                for r in rs
            ]
            ax.loglog([r["seconds"] for r in rs], err, marker="o", ms=3, label=adapter)
        ax.set_title(scene, fontsize=9)
        ax.set_xlabel("wall time per impact [s]")
    axes[0][0].set_ylabel("largest relative error (e, t_c, q_max) [-]")
    handles: dict = {}
    for ax in axes[0]:
        for h, lab in zip(*ax.get_legend_handles_labels(), strict=True):
            handles.setdefault(lab, h)
    if handles:
        fig.legend(list(handles.values()), list(handles), loc="outside lower center",
                   ncol=min(4, len(handles)), fontsize=8.5)  # fmt: skip
    fig.suptitle("speed against error (dotted: exact solver)", fontsize=10)
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=120)
    return out
