"""The report's figures are readable where they are shown (issue 26 item 7, issue 31).

Every legend is at 8 pt or more and off the data (no drawn point or line of any panel
under it), and every axis that carries data is labelled with its unit in brackets
(``[-]`` for a dimensionless quantity). Read from matplotlib's objects, not from pixels:
each figure function of the report is run on the committed ``reports/results.json`` (the
Fig. 1 runs are recomputed, about 2 s) with ``Figure.savefig`` caught, and the figure is
drawn once so that legends have their place; the codes' speed-against-error figures
(``bench_*.png``, `reference_impl.bench.scorecard.compare.plot_speed_error`) included.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("matplotlib")

import pandas as pd  # noqa: E402
from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from reference_impl.bench.scorecard.compare import plot_speed_error  # noqa: E402
from reference_impl.claims import fig1 as fig1_claim  # noqa: E402
from reference_impl.claims import sec6_assemblies  # noqa: E402
from reference_impl.report import (  # noqa: E402
    _assemblies,
    _dtmap,
    _fig1,
    _hardcases,
    _laws,
    _steps,
    _wp,
)
from reference_impl.studies.paper import FIG1  # noqa: E402
from verification.assertions import assert_true  # noqa: E402

RESULTS = Path(__file__).resolve().parents[1] / "reports" / "results.json"
# Smallest legend and axis-label size [pt]: the "readable at the size shown".
MIN_PT = 8.0
UNIT = re.compile(r"\[[^\]]+\]")
# Points drawn between two data points of a line (a legend must not cover a segment).
_PER_SEGMENT = 16
FIGURES = (
    "fig1", "dt_crit_map", "hard_cases", "damping_laws", "work_precision", "steps", "bench",
    "assemblies",
)  # fmt: skip


def _finite(x):
    """results.json's "inf"/"-inf" strings and nulls back to floats (recursively)."""
    if isinstance(x, dict):
        return {k: _finite(v) for k, v in x.items()}
    if isinstance(x, list):
        return [_finite(v) for v in x]
    if x in ("inf", "-inf"):
        return float(x)
    return math.nan if x is None else x


@pytest.fixture(scope="module")
def results():
    if not RESULTS.is_file():
        pytest.skip("reports/results.json not generated")
    return json.loads(RESULTS.read_text())


def _draw(name: str, r: dict, tmp: Path, monkeypatch) -> list[Figure]:
    """The report's figures of one kind, as matplotlib figures (nothing written)."""
    figs: list[Figure] = []
    monkeypatch.setattr(Figure, "savefig", lambda self, *a, **k: figs.append(self))
    if name == "fig1":
        _fig1.fig1_figure(fig1_claim.runs(), tmp / "x.png", FIG1, fig1_claim.RTOL)
    elif name == "dt_crit_map":
        _dtmap.map_figure(pd.DataFrame(_finite(r["dt_crit_map"])), tmp / "x.png")
    elif name == "hard_cases":
        hc = r["hard_cases"]
        _hardcases.sweeps_figure(_finite(hc["sweeps"]), tmp / "x.png", 0.735, hc["settings"])
    elif name == "damping_laws":
        _laws.laws_figure(r["damping_laws"], tmp / "x.png")
    elif name == "work_precision":
        fams = {x["scene"]: x["family"] for x in r["work_precision_families"]["rows"]}
        df = pd.DataFrame(_finite(r["work_precision"]))
        _wp.wp_figures(df, tmp, r["work_precision_scenes"], fams)
    elif name == "steps":
        if not r["steps_per_contact"]:
            pytest.skip("the committed report has no contact codes")
        for code in r["steps_per_contact"]:
            _steps.plot_steps(code, tmp / "x.png", r["steps_per_contact_settings"]["scenes"])
    elif name == "assemblies":
        # The claim's rows; a report written before hcv-results/1.2 has no P_fail curves in
        # them: the quick measurement's (a few seconds) are drawn instead.
        rows = next(c for c in r["claims"] if c["id"] == sec6_assemblies.ID)["measured"]["rows"]
        if "p_fail_by_horizon" not in rows[0]:
            rows = sec6_assemblies.measure(quick=True).figures["rows"]
        _assemblies.assemblies_figures(rows, tmp)
    elif name == "bench":
        if not r["adapters"]:
            pytest.skip("the committed report has no contact codes")
        for doc in r["adapters"]:
            plot_speed_error(doc["speed_error"], tmp / "x.png")
    assert figs, f"got no figure drawn for {name}, should be at least one"
    return figs


def _points(ax) -> np.ndarray:
    """Display coordinates of what the panel draws inside itself: the vertices of every
    line (and points along its segments) and the offsets of every scatter."""
    out = []
    for line in ax.get_lines():
        if not line.get_visible():
            continue
        xy = line.get_transform().transform(np.asarray(line.get_xydata(), float))
        xy = xy[np.isfinite(xy).all(axis=1)]
        if len(xy) > 1:
            t = np.linspace(0.0, 1.0, _PER_SEGMENT)[:, None, None]
            xy = (xy[:-1] + t * (xy[1:] - xy[:-1])).reshape(-1, 2)
        out.append(xy)
    for coll in ax.collections:
        off = np.asarray(coll.get_offsets(), float)
        if off.size:
            xy = coll.get_offset_transform().transform(off)
            out.append(xy[np.isfinite(xy).all(axis=1)])
    pts = np.concatenate(out) if out else np.empty((0, 2))
    box = ax.bbox
    inside = (pts[:, 0] >= box.x0) & (pts[:, 0] <= box.x1) & (pts[:, 1] >= box.y0)
    return pts[inside & (pts[:, 1] <= box.y1)]


def _legends(fig: Figure) -> list:
    return [ax.get_legend() for ax in fig.axes if ax.get_legend()] + list(fig.legends)


@pytest.mark.parametrize("name", FIGURES)
def test_legends_are_readable_and_off_the_data(name, results, tmp_path, monkeypatch):
    for fig in _draw(name, results, tmp_path, monkeypatch):
        FigureCanvasAgg(fig).draw()  # the layout runs, legends take their place
        renderer = fig.canvas.get_renderer()
        title = fig.get_suptitle()[:50]
        for leg in _legends(fig):
            sizes = [t.get_fontsize() for t in leg.get_texts()]
            if leg.get_title().get_text():
                sizes.append(leg.get_title().get_fontsize())
            assert_true(
                min(sizes) >= MIN_PT,
                got=f"legend text at {min(sizes):g} pt in {title!r}",
                should=f">= {MIN_PT:g} pt",
                claim="report",
                call=f"report figure {name}",
            )
            box = leg.get_window_extent(renderer)
            for ax in fig.axes:
                pts = _points(ax)
                under = pts[
                    (pts[:, 0] > box.x0)
                    & (pts[:, 0] < box.x1)
                    & (pts[:, 1] > box.y0)
                    & (pts[:, 1] < box.y1)
                ]
                assert_true(
                    len(under) == 0,
                    got=f"{len(under)} drawn points of panel {ax.get_title()!r} under the "
                    f"legend of {title!r}",
                    should="none (legend off the data)",
                    claim="report",
                    call=f"report figure {name}",
                )


@pytest.mark.parametrize("name", FIGURES)
def test_every_axis_is_labelled_with_its_unit(name, results, tmp_path, monkeypatch):
    for fig in _draw(name, results, tmp_path, monkeypatch):
        for ax in fig.axes:
            if not ax.get_visible() or not (ax.get_lines() or ax.collections):
                continue
            for axis, shared in (
                (ax.xaxis, ax.get_shared_x_axes()),
                (ax.yaxis, ax.get_shared_y_axes()),
            ):
                # A shared axis is labelled once (on the first panel of the row or column).
                labels = [
                    getattr(s, f"{axis.axis_name}axis").get_label() for s in shared.get_siblings(ax)
                ]
                label = next((lab for lab in labels if lab.get_text()), axis.get_label())
                text = label.get_text()
                assert_true(
                    bool(UNIT.search(text)) and label.get_fontsize() >= MIN_PT,
                    got=f"{axis.axis_name} label {text!r} at {label.get_fontsize():g} pt "
                    f"(panel {ax.get_title()!r})",
                    should=f"a label with its unit in brackets, >= {MIN_PT:g} pt",
                    claim="report",
                    call=f"report figure {name}",
                )
