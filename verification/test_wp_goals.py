"""Issue 38's goals 3 and 4 read off the work-precision record (`reference_impl.report._wp_goals`).

The table is computed from the record, never typed: each verdict here is checked on a small
record whose answer is known by hand (met, a ratio short, no peer reaching the accuracy, ours
not reaching it), on the committed record, and on hostile records (one line per panel left
out, no traceback, nothing rendered as HTML).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from reference_impl.report._wp_goals import GOALS, goal_rows, goals_text

ROOT = Path(__file__).resolve().parents[1]


def _panel(law, ours, prepared, peers, checked=True, family="Hertz p=1.5"):
    """A panel of (error, us) pairs per curve."""

    def curve(pts):
        return [{"rtol": None, "max_rel_error": e, "us": us} for e, us in pts]

    curves = {"ours": curve(ours), "prepared": curve(prepared)}
    curves.update({k: curve(v) for k, v in peers.items()})
    return {
        "family": family,
        "law": law,
        "proxy_check": {"bounds_held": True} if checked else {"bounds_held": None},
        "curves": curves,
    }


def _rows(*panels):
    rows, left = goal_rows({"panels": list(panels)})
    return {(r["law"], r["accuracy"]): r for r in rows}, left


def test_met_and_ratios_by_hand():
    # ours: 10 us one-shot / 4 us prepared at every accuracy; the peer 50 us at 1e-8 and
    # 200 us at 1e-15: ratios 5 and 12.5 at 1e-8, 20 and 50 at 1e-14 (universal goals met).
    p = _panel("universal", [(0.0, 10.0)], [(0.0, 4.0)], {"dop": [(1e-9, 50.0), (1e-15, 200.0)]})
    rows, left = _rows(p)
    assert left == []
    r8, r14 = rows[("universal", 1e-8)], rows[("universal", 1e-14)]
    assert (r8["ratio_one_shot"], r8["ratio_prepared"]) == (5.0, 12.5), (
        f"got {r8}, should be 5x, 12.5x [1e-8]"
    )
    assert (r14["ratio_one_shot"], r14["ratio_prepared"]) == (20.0, 50.0), (
        f"got {r14}, should be 20x, 50x [1e-14]"
    )
    assert r8["verdict"] == r14["verdict"] == "met", (
        f"got {r8['verdict']}, {r14['verdict']}, should be met [goal 3]"
    )


def test_cheapest_point_within_the_accuracy():
    # Two peers: the cheaper one reaches only 1e-7, so at 1e-8 the other is the fastest there.
    p = _panel(
        {"law": "linear", "c": 1.0},
        [(1e-9, 30.0), (0.0, 35.0)],
        [(1e-9, 15.0), (0.0, 20.0)],
        {"a": [(1e-7, 5.0)], "b": [(1e-9, 40.0), (1e-15, 90.0)]},
    )
    rows, _ = _rows(p)
    r8, r14 = rows[("linear", 1e-8)], rows[("linear", 1e-14)]
    assert (r8["peer"], r8["ours_us"], r8["prepared_us"]) == ("b", 30.0, 15.0), f"got {r8} [1e-8]"
    assert (r14["peer"], r14["ours_us"], r14["prepared_us"]) == ("b", 35.0, 20.0), (
        f"got {r14} [1e-14]"
    )
    # 40 / 15 = 2.67 >= 2 and 40 / 30 = 1.33 >= 1: met; 90 / 35 = 2.57 >= 2, 90 / 20 = 4.5 >= 3.
    assert r8["verdict"] == "met" and r14["verdict"] == "met", (
        f"got {r8['verdict']}, {r14['verdict']}"
    )


def test_short_ratio_is_not_met_with_its_figures():
    # The cap + dashpot case of the record: ours slower than the peer at 1e-8.
    p = _panel(
        {"law": "linear", "c": 1.0}, [(0.0, 255.0)], [(0.0, 230.0)], {"dop": [(1e-9, 123.0)]}
    )
    r8 = _rows(p)[0][("linear", 1e-8)]
    assert r8["verdict"] == "not met", f"got {r8['verdict']}, should be not met [0.48x < 1x]"
    assert "0.48× < 1×" in r8["why"] and "0.53× < 2×" in r8["why"], f"got {r8['why']!r}"


def test_no_peer_at_the_accuracy_is_not_judged_and_names_the_closest():
    p = _panel("universal", [(0.0, 10.0)], [(0.0, 5.0)], {"s": [(6.2e-14, 285.0), (1e-9, 50.0)]})
    r14 = _rows(p)[0][("universal", 1e-14)]
    assert r14["verdict"] == "not judged" and r14["peer"] is None, f"got {r14}"
    assert "s, 6.2e-14 at 285 µs" in r14["why"], (
        f"got {r14['why']!r}, should name the closest point"
    )


def test_ours_not_reaching_the_accuracy_is_not_met():
    p = _panel("universal", [(1e-12, 10.0)], [(1e-12, 5.0)], {"s": [(1e-15, 500.0)]})
    r14 = _rows(p)[0][("universal", 1e-14)]
    assert r14["verdict"] == "not met" and "ours does not reach" in r14["why"], f"got {r14}"


def test_unchecked_panel_is_said():
    p = _panel(
        {"law": "linear", "c": 1.0}, [(0.0, 5.0)], [(0.0, 2.0)], {"d": [(0.0, 50.0)]}, checked=False
    )
    text = goals_text({"panels": [p]})
    assert text.count("no 30-digit check") == 2, f"got {text!r}, should flag both rows"


def test_committed_record_reads_whole():
    path = ROOT / "reports" / "bench" / "workprecision.json"
    if not path.exists():
        pytest.skip("no committed work-precision record")
    wp = json.loads(path.read_text())
    rows, left = goal_rows(wp)
    assert left == [], f"got {left}, should read every panel of the committed record"
    assert len(rows) == 2 * len(wp["panels"]), f"got {len(rows)} rows, should be 2 per panel"
    for r in rows:
        goals = GOALS["universal" if r["law"] == "universal" else "law"]
        assert (r["accuracy"], r["goal_one_shot"], r["goal_prepared"]) in goals, f"got {r}"
        if r["verdict"] == "met":
            assert (
                r["ratio_one_shot"] >= r["goal_one_shot"]
                and r["ratio_prepared"] >= r["goal_prepared"]
            ), f"got {r}"


@pytest.mark.parametrize(
    "bad, why",
    [
        ("not a panel", "not an object"),
        ({"curves": "x"}, "no 'ours'"),
        ({"curves": {"ours": [], "prepared": []}}, "no peer curve"),
        (
            {"curves": {"ours": [{"max_rel_error": math.nan, "us": 1.0}], "prepared": [], "p": []}},
            "nan",
        ),
        ({"curves": {"ours": [{"max_rel_error": 0.0, "us": "1"}], "prepared": [], "p": []}}, "'1'"),
        (
            {"curves": {"ours": [{"max_rel_error": 0.0, "us": -1.0}], "prepared": [], "p": []}},
            "negative",
        ),
        (
            {"curves": {"ours": [{"max_rel_error": True, "us": 1.0}], "prepared": [], "p": []}},
            "True",
        ),
        ({"curves": {"ours": {}, "prepared": [], "p": []}}, "not a list"),
        ({"curves": {"ours": [1], "prepared": [], "p": []}}, "not an object"),
    ],
)
def test_hostile_panel_is_left_out_with_its_reason(bad, why):
    good = _panel("universal", [(0.0, 10.0)], [(0.0, 5.0)], {"s": [(1e-15, 500.0)]})
    rows, left = goal_rows({"panels": [bad, good]})
    assert len(left) == 1 and left[0].startswith("panel 0 left out") and why in left[0], (
        f"got {left}, should name {why!r} [hostile panel]"
    )
    assert len(rows) == 2, f"got {len(rows)} rows, should keep the good panel's 2"


@pytest.mark.parametrize("wp", [None, [], {"panels": "x"}, {"panels": None}])
def test_record_without_panels(wp):
    assert goal_rows(wp) == ([], ["no panels in the record"])


def test_record_text_is_not_html_or_a_column_break():
    p = _panel(
        "universal",
        [(0.0, 10.0)],
        [(0.0, 5.0)],
        {"<img src=x>|": [(1e-15, 500.0)]},
        family="<script>alert(1)</script> | x",
    )
    text = goals_text({"panels": [p]})
    assert "<script" not in text and "<img" not in text, f"got {text!r}, should escape HTML"
    row = [ln for ln in text.splitlines() if ln.startswith("| &lt;script")]
    assert row and row[0].count(" | ") == 9, f"got {row}, should keep 10 columns"
