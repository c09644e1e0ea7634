"""Issue 38's goals 3 and 4, read off the work-precision record: a table per panel and accuracy.

`benchmarks.bench_workprecision` records, per panel (a family and a law), the CPU time per
impact and the largest relative error over its random impacts for ours (one-shot and
prepared, at each ``rtol``) and for each peer over its tolerance ladder. The issue states its
goals at two accuracies, against the fastest peer at equal error:

* goal 3, the universal law: at 1e-8 ``prepare`` >= 2x and one-shot ``solve_impact`` >= 1x;
  at <= 1e-14 one-shot >= 5x and ``prepare`` >= 10x;
* goal 4, a general damping law: at 1e-8 ``prepare_law`` >= 2x and one-shot >= 1x; at
  <= 1e-14 ``prepare_law`` >= 3x and one-shot >= 2x.

At an accuracy ``a`` each side is taken at its cheapest point whose error is <= ``a``
(ours at any ``rtol``, a peer at any rung), as the figure shows them; a ratio is the peer's
time over ours. Where no peer reaches ``a`` the goal is not judged (there is no equal-error
ratio; the row gives the closest peer point instead) and where ours does not reach it the
goal is not met. The errors are the record's: against ours at full accuracy, itself checked
against a 30-digit truth on a subset where one exists (the row says when it does not).

The record is input (a file anyone can edit): a panel whose curves are not lists of finite
numbers is left out with one line saying why, never a traceback.
"""

from __future__ import annotations

import math

from reference_impl.report._text import markdown_text

__all__ = ["GOALS", "goal_rows", "goals_text"]

# (accuracy, one-shot goal, prepared goal) per kind of law: issue 38's goals 3 and 4.
GOALS = {
    "universal": ((1e-8, 1.0, 2.0), (1e-14, 5.0, 10.0)),
    "law": ((1e-8, 1.0, 2.0), (1e-14, 2.0, 3.0)),
}
_OURS = ("ours", "prepared")


def _points(curve) -> list[tuple[float, float]]:
    """(error, us) of each point of a curve; ValueError where a point is not two finite
    non-negative numbers."""
    if not isinstance(curve, list):
        raise ValueError(f"a curve is {type(curve).__name__}, not a list")
    pts = []
    for p in curve:
        if not isinstance(p, dict):
            raise ValueError(f"a point is {type(p).__name__}, not an object")
        e, us = p.get("max_rel_error"), p.get("us")
        for name, x in (("max_rel_error", e), ("us", us)):
            if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x):
                raise ValueError(f"{name} = {x!r} is not a finite number")
            if x < 0:
                raise ValueError(f"{name} = {x!r} is negative")
        pts.append((float(e), float(us)))
    return pts


def _cheapest(pts, acc: float):
    """The least time among the points whose error is <= acc, or None."""
    ok = [us for e, us in pts if e <= acc]
    return min(ok) if ok else None


def _panel_row(panel: dict) -> list[dict]:
    """One row per accuracy of the panel's goal (see `goal_rows`)."""
    curves = panel.get("curves")
    if not isinstance(curves, dict) or not all(k in curves for k in _OURS):
        raise ValueError("no 'ours' and 'prepared' curves")
    pts = {str(k): _points(v) for k, v in curves.items()}
    peers = {k: v for k, v in pts.items() if k not in _OURS}
    if not peers:
        raise ValueError("no peer curve")
    law = panel.get("law")
    kind = "universal" if law == "universal" else "law"
    rows = []
    for acc, g_one, g_prep in GOALS[kind]:
        one, prep = _cheapest(pts["ours"], acc), _cheapest(pts["prepared"], acc)
        at = {k: _cheapest(v, acc) for k, v in peers.items()}
        at = {k: v for k, v in at.items() if v is not None}
        row = {
            "accuracy": acc,
            "goal_one_shot": g_one,
            "goal_prepared": g_prep,
            "ours_us": one,
            "prepared_us": prep,
            "peer": None,
            "peer_us": None,
        }
        if at:
            name = min(at, key=at.get)
            row.update(peer=name, peer_us=at[name])
            row["ratio_one_shot"] = at[name] / one if one else None
            row["ratio_prepared"] = at[name] / prep if prep else None
            if one is None or prep is None:
                row["verdict"] = "not met"
                row["why"] = f"ours does not reach {acc:.0e}"
            else:
                short = [
                    f"{what} {r:.2f}× < {g:g}×"
                    for what, r, g in (
                        ("one-shot", row["ratio_one_shot"], g_one),
                        ("prepared", row["ratio_prepared"], g_prep),
                    )
                    if r < g
                ]
                row["verdict"] = "not met" if short else "met"
                row["why"] = "; ".join(short)
        else:
            # The closest any peer comes: its most accurate point (least time on a tie).
            name, (e, us) = min(
                ((k, min(v, key=lambda p: (p[0], p[1]))) for k, v in peers.items() if v),
                key=lambda kv: (kv[1][0], kv[1][1]),
            )
            row["verdict"] = "not judged"
            row["why"] = f"no peer reaches {acc:.0e}; the closest, {name}, {e:.1e} at {us:.0f} µs"
        rows.append(row)
    return rows


def goal_rows(wp: dict) -> tuple[list[dict], list[str]]:
    """The goal rows of a work-precision record, and a line per panel left out.

    Parameters
    ----------
    wp : dict
        The record of `benchmarks.bench_workprecision` (times in µs of CPU per impact,
        errors relative).

    Returns
    -------
    rows : list of dict
        Per panel and accuracy: ``family``, ``law``, ``accuracy``, ``ours_us`` (one-shot),
        ``prepared_us``, ``peer``, ``peer_us`` (µs; None where nothing reaches the
        accuracy), ``ratio_one_shot``, ``ratio_prepared``, the goals, ``verdict`` ("met",
        "not met", "not judged") and ``why``, and ``unchecked`` (True where the panel's
        errors have no 30-digit check).
    left_out : list of str
        "panel N left out: <why>" for each panel that could not be read.
    """
    rows, left_out = [], []
    panels = wp.get("panels") if isinstance(wp, dict) else None
    if not isinstance(panels, list):
        return [], ["no panels in the record"]
    for i, panel in enumerate(panels):
        try:
            if not isinstance(panel, dict):
                raise ValueError(f"a panel is {type(panel).__name__}, not an object")
            prs = _panel_row(panel)
        except ValueError as exc:
            left_out.append(f"panel {i} left out: {exc}")
            continue
        check = panel.get("proxy_check")
        unchecked = not (isinstance(check, dict) and check.get("bounds_held") is True)
        law = panel.get("law")
        law_name = law if isinstance(law, str) else str((law or {}).get("law", law))
        for r in prs:
            rows.append(
                {
                    "family": str(panel.get("family", "?")),
                    "law": law_name,
                    "unchecked": unchecked,
                    **r,
                }
            )
    return rows, left_out


def _cell(text) -> str:
    """A table cell from the record: no column or line break, no raw HTML or unsafe link."""
    return markdown_text(str(text).replace("|", "\\|").replace("\n", " "))


def _us(x) -> str:
    return "—" if x is None else f"{x:.0f} µs" if x >= 10 else f"{x:.1f} µs"


def _ratio(x) -> str:
    return "—" if x is None else f"{x:.2f}×"


def goals_text(wp: dict) -> str:
    """A markdown table of `goal_rows`, with the left-out panels under it."""
    rows, left_out = goal_rows(wp)
    lines = [
        "Issue 38's goals 3 (universal law) and 4 (a damping law) on the work-precision record: "
        "each side at its cheapest point within the accuracy, ratio = the fastest peer's time / ours.",
        "",
        "| family | law | accuracy | one-shot | prepared | fastest peer there | ratio one-shot "
        "| ratio prepared | goal (one-shot, prepared) | verdict |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        peer = "—" if r["peer"] is None else f"{_cell(r['peer'])}: {_us(r['peer_us'])}"
        verdict = r["verdict"] if r["verdict"] != "not met" else "**not met**"
        if r["why"]:
            verdict += f": {_cell(r['why'])}"
        if r["unchecked"]:
            verdict += " (errors against ours, no 30-digit check)"
        acc = f"≤ {r['accuracy']:.0e}"
        lines.append(
            f"| {_cell(r['family'])} | {_cell(r['law'])} | {acc} | {_us(r['ours_us'])} | "
            f"{_us(r['prepared_us'])} | {peer} | {_ratio(r.get('ratio_one_shot'))} | "
            f"{_ratio(r.get('ratio_prepared'))} | ≥ {r['goal_one_shot']:g}×, "
            f"≥ {r['goal_prepared']:g}× | {verdict} |"
        )
    lines += [f"- {_cell(x)}" for x in left_out]
    return "\n".join(lines)
