"""The report's section on benchmarked contact codes (hcv report --adapter): side by side, then per code."""

from __future__ import annotations

from reference_impl.bench.scorecard.report import UNITS as _UNITS
from reference_impl.bench.scorecard.report import format_value as _fmt
from reference_impl.bench.scorecard.report import format_with_unit as _fmt_v
from reference_impl.bench.scorecard.report import json_number as _bench_num
from reference_impl.bench.scorecard.report import side_by_side
from reference_impl.report._blocks import IMG, H, P, T

# Column headers of each code's own table (`_adapter_rows`).
_CODE_COLUMNS = [
    "variant",
    "scene",
    "metric",
    "measured",
    "expected",
    "error",
    "tolerance",
    "at v0 (m/s)",
    "result",
    "why",
]


def _adapter_rows(d: dict) -> tuple[list, list]:
    """One code's metrics (skips left out) as rows of `_CODE_COLUMNS`, with cell flags.

    ``measured`` / ``expected`` are the compared quantities (with their unit), ``error``
    what the tolerance bounds (`reference_impl.bench.scorecard.report.metric_columns`).
    """

    rows, flags = [], []
    for m in d.get("metrics", []):
        status = m.get("status", "")
        if status in ("skip", "n/a"):  # n/a: the metric does not apply
            continue
        unit = _UNITS.get(m.get("metric", ""), "")
        at = _bench_num(m.get("at_v0"))
        rows.append(
            [
                m.get("variant", ""),
                m.get("scene", ""),
                m.get("metric", ""),
                _fmt_v(_bench_num(m.get("measured")), unit),
                _fmt_v(_bench_num(m.get("expected")), unit),
                _fmt(_bench_num(m.get("error"))),
                str(m.get("tolerance") or ""),
                f"{at:g}" if isinstance(at, float) else "",
                {"fail": "FAIL"}.get(status, status),
                m.get("explanation", "") if status == "fail" else "",
            ]
        )
        verdict = "bad" if status == "fail" else "good"
        flags.append([None] * 8 + [verdict, None])
    return rows, flags


def _scenes_no_code_ran(docs) -> dict[str, str]:
    """Scenes whose every metric, in every document, was skipped -> the first skip reason."""
    seen: dict[str, str] = {}
    ran: set[str] = set()
    for d in docs:
        for m in d.get("metrics", []):
            scene = m.get("scene", "")
            if m.get("status") in ("skip", "n/a"):
                seen.setdefault(scene, m.get("explanation", ""))
            else:
                ran.add(scene)
    return {k: v for k, v in seen.items() if k not in ran}


def _carried(r) -> list:
    """A marked paragraph when these sections were carried from an earlier run."""
    c = r.get("carried")
    if not c:
        return []
    dirty = ", with uncommitted changes" if c.get("git_dirty") else ""
    return [
        P(
            f"Not run by this report ({c.get('reason', 'carried')}): the sections on "
            f"{', '.join(map(str, c.get('adapters') or []))} below are carried unchanged from "
            f"the report of {c['generated_utc']} (commit "
            f"{str(c.get('git_commit') or 'unknown')[:12]}{dirty}). `hcv report --adapter NAME` "
            "measures a code again.",
            "warn",
        )
    ]


def _adapters(r) -> list:
    """Scorecards of the contact codes given with ``hcv report --adapter``: first all codes
    side by side (`reference_impl.bench.scorecard.report.side_by_side`), then each code's own table."""

    docs = r.get("adapters") or []
    if not docs:
        return []
    header, sbs = side_by_side(docs)
    sbs_flags = [
        [None] * 3
        + [
            "bad" if c.endswith("FAIL") else ("good" if c.endswith("pass") else None)
            for c in row[3:]
        ]
        for row in sbs
    ]
    blocks = [
        H(2, "Contact codes benchmarked (hcv report --adapter)", "adapters"),
        *_carried(r),
        P(
            "Each code ran the bench scenes through its adapter; every metric is compared "
            "with its reference (the exact solution of the law the code declares it "
            "integrates, or the restitution it was asked for) under the tolerance shown "
            "(`hcv bench`, reference_impl/bench/scorecard/tolerances.toml)."
        ),
        H(3, "Side by side"),
        P(
            "One row per scene and metric, one column per adapter variant: the measured "
            "value (at the worst impact speed for restitution, penetration and contact "
            "time; the bounded quantity itself for spreads, convergence orders and drifts) "
            "and its verdict; "
            '"-" where the variant skipped the scene. `reference` is the asked '
            "restitution where every code was asked the same; otherwise each code is "
            "compared with the exact solution of its own declared law (tables below)."
        ),
        T(header, sbs, sbs_flags),
    ]
    unrun = _scenes_no_code_ran(docs)
    if unrun:
        blocks.append(
            P(
                "Scenes no variant ran (every metric skipped): "
                + "; ".join(f"{scene} (first reason given: {why})" for scene, why in unrun.items())
                + ".",
                "warn",
            )
        )
    for d in docs:
        s = d.get("summary", {})
        rows, flags = _adapter_rows(d)
        blocks += [
            H(
                3,
                f"{d['adapter']}: {s.get('pass', 0)} pass, {s.get('fail', 0)} fail, "
                f"{s.get('skip', 0)} skipped",
            ),
            T(_CODE_COLUMNS, rows, flags),
        ]
        safe = "".join(ch if ch.isalnum() or ch in "-_" else "_" for ch in str(d["adapter"]))[:60]
        fig = f"bench_{safe}.png"
        if f"figures/{fig}" in r.get("figures", []):  # listed, so checked as a file
            blocks.append(
                IMG(fig, f"Speed against error of {d['adapter']} against the exact solution.")
            )
    return blocks
