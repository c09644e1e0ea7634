"""The benchmark's scorecard rendered for people: the rich scorecard, markdown and the plot.

This module only renders: the run (`reference_impl.bench.scorecard.runner`) writes its
JSON (`reference_impl.bench.scorecard._json.write_json`, schema ``hcv-bench/1``) and JUnit
XML (`reference_impl.bench.scorecard._junit.write_junit`) without importing it.

* `render_scorecard`: the scorecard as a rich table (what ``hcv bench`` prints);
  `render_speed_error`: the speed-against-error table.
* `scorecard_markdown`: for ``hcv report``; `side_by_side` and `plot_speed_error`
  (home: `reference_impl.bench.scorecard.compare`, re-exported here) as well.

Metric statuses: "pass", "fail", "skip", "error" (the suite's reference failed) and
"n/a" (the metric does not apply to the scene's kind, damping or speeds). Every output
above knows all five (`STATUSES`). Every metric belongs to one of two verdicts
("implementation", "delivery"), shown in its own column and summed per code.

Here: the scorecard for people (plain text, rich, markdown); the compared values of a
metric are read by `reference_impl.bench.scorecard._cells.metric_columns` (importable from
here).
"""

from __future__ import annotations

import math

from reference_impl._atomic import atomic_write
from reference_impl.bench.scorecard._cells import (
    _OURS,
    _PLAIN_STATUS,
    _UNITS,
    _fmt,
    _fmt_v,
    metric_columns,
)
from reference_impl.bench.scorecard._records import NA, VERDICTS

__all__ = [
    "STATUSES",
    "UNITS",
    "format_value",
    "format_with_unit",
    "gate_lines",
    "json_number",
    "metric_columns",
    "plot_speed_error",
    "render_scorecard",
    "render_speed_error",
    "scorecard_markdown",
    "scorecard_text",
    "side_by_side",
    "side_by_side_markdown",
    "verdict_text",
    "write_markdown",
]

# Every metric status, in the order the summaries list them ("n/a": the metric does not
# apply to the scene; "skip": it applies but could not be run).
STATUSES = ("pass", "fail", "skip", "error", NA)


_STATUS = {
    "pass": "[green]pass[/]",
    "fail": "[bold red]FAIL[/]",
    "skip": "[dim]skip[/]",
    "error": f"[bold magenta]{_OURS}[/]",
    NA: "[dim]n/a[/]",
}


def _count_text(counts: dict) -> str:
    """Counts as text, e.g. "3 pass, 1 fail, 2 skipped" (+ ", 1 ERROR (ours)", ", 4 n/a")."""
    text = f"{counts.get('pass', 0)} pass, {counts.get('fail', 0)} fail, {counts.get('skip', 0)} skipped"
    if counts.get("error"):
        text += f", {counts['error']} {_OURS}"
    if counts.get(NA):
        text += f", {counts[NA]} n/a"
    return text


def _verdict_word(items) -> str:
    """PASS / FAIL / ERROR (ours) / nothing measured, of one verdict's metrics."""
    statuses = {m.status for m in items}
    if "fail" in statuses:
        return "FAIL"
    if "error" in statuses:
        return _OURS
    return "pass" if "pass" in statuses else "nothing measured"


def verdict_text(items) -> str:
    """The two verdicts of some metrics as one phrase: "implementation pass, delivery FAIL"."""
    return ", ".join(
        f"{v} {_verdict_word([m for m in items if m.verdict == v])}"
        for v in VERDICTS
        if any(m.verdict == v for m in items)
    )


def _fail_line(result, m) -> str:
    """One failed metric in one line: measured, expected, error (and its split), the
    tolerance; a metric that compared nothing (a run failed) gives its reason instead."""
    c = metric_columns(result, m)
    if c["measured"] is None or c["reference"] is None:
        return f"    FAIL {m.scene} / {m.metric}: {m.explanation}"
    at = f" at v0 = {c['v0']:g} m/s" if c["v0"] is not None else ""
    what = [f"error {_fmt(c['error'])}"] if c["error"] is not None else []
    if c["model_error"] is not None or c["step_error"] is not None:
        what.append(f"model {_fmt(c['model_error']) or '-'}, step {_fmt(c['step_error']) or '-'}")
    for key in ("ratio", "order"):
        if c[key] is not None:
            what.append(f"{key} {_fmt(c[key])}")
    what.append(f"tolerance {c['tolerance'] or '-'}")
    return (
        f"    FAIL {m.scene} / {m.metric} ({c['verdict']}): measured "
        f"{_fmt_v(c['measured'], c['unit'])}, expected {_fmt_v(c['reference'], c['unit'])}"
        f"{at}; " + "; ".join(what)
    )


def _summary_lines(result) -> list[str]:
    """Per code: pass / fail counts and its two verdicts, then each failing metric with
    measured vs expected, then each metric our reference could not decide ("error")."""
    lines = [
        f"hcv bench {result.adapter}: {_count_text(result.counts())}"
        + (" (interrupted)" if result.interrupted else "")
    ]
    by_variant: dict[str, list] = {}
    for m in result.metrics:
        by_variant.setdefault(m.variant, []).append(m)
    for variant, items in by_variant.items():
        counts = {s: sum(m.status == s for m in items) for s in STATUSES}
        both = verdict_text(items)
        lines.append(f"  {variant}: {_count_text(counts)}" + (f"; {both}" if both else ""))
        # a declined scene: one line with the reason (not one per metric), whoever declined
        for ctx in result.contexts:
            if ctx.variant == variant and ctx.skipped:
                lines.append(f"    SKIPPED {ctx.scene}: {ctx.skipped}")
            if ctx.variant == variant and getattr(ctx, "rigid", ""):
                lines.append(f"    NO PENETRATION {ctx.scene}: {ctx.rigid}; the rest n/a")
        for m in items:
            if m.status == "error":
                lines.append(f"    {_OURS} {m.scene} / {m.metric}: {m.explanation}")
            if m.status == "fail":
                lines.append(_fail_line(result, m))
    return lines


def gate_lines(result, gate) -> list[str]:
    """What ``hcv bench --gate[=WHICH]`` prints last: the verdict(s) it read and why."""
    which = "both" if gate is True else gate
    mine = result.gated(which)
    c = {s: sum(m.status == s for m in mine) for s in STATUSES}
    status = result.exit_status(which)
    word = {0: "pass", 1: "FAIL"}.get(status, "ERROR (internal error of the reference)")
    scope = "gate" if which == "both" else f"gate ({which})"
    if not any(m.status in ("pass", "fail", "error") for m in mine):
        return [
            f"{scope}: FAIL (nothing measured: all {len(mine)} metrics skipped or "
            "n/a, the SKIPPED lines above and --show-skipped say why; a gate that "
            "measured nothing does not pass)"
        ]
    return [
        f"{scope}: {word} ({c['fail']} of {c['pass'] + c['fail'] + c['error']} "
        f"metrics failed, {c['error']} undecided by our reference; {verdict_text(mine)})"
    ]


_COLUMNS = (
    "adapter", "scene", "verdict", "metric", "v0", "measured", "expected", "error",
    "model err", "step err", "ratio", "order", "tolerance", "result",
)  # fmt: skip
_RIGHT = {4, 5, 6, 7, 8, 9, 10, 11}


def _common_speeds(result) -> dict:
    """(scene, metric) -> the speed every code's row shows: the worst over the codes.

    Per code, a metric reports its own worst speed; with several codes (variants) on
    one scene, every passing row of a metric is read at one speed so that they compare
    side by side (a failed row keeps the code's own worst speed, the one its FAIL line
    names).
    """
    worst: dict = {}
    for m in result.metrics:
        if len({x.variant for x in result.metrics}) < 2:
            return {}
        if m.status not in ("pass", "fail") or not getattr(m, "per_v0", None):
            continue
        for r in m.per_v0:
            lim, err = r.get("limit"), r.get("error")
            score = err / lim if isinstance(err, float) and lim else math.inf
            key = (m.scene, m.metric)
            if key not in worst or score > worst[key][0]:
                worst[key] = (score, r["v0"])
    return {k: v[1] for k, v in worst.items()}


def _rows(result, show_skipped: bool) -> list[list[str]]:
    rows = []
    common = _common_speeds(result)
    for m in result.metrics:
        if m.status in ("skip", NA) and not show_skipped:
            continue
        c = metric_columns(result, m)
        v0 = common.get((m.scene, m.metric))
        # a failed metric keeps its own worst speed: its row and its FAIL line name one v0
        if v0 is not None and v0 != c["v0"] and m.status != "fail":
            at = next((r for r in m.per_v0 if r["v0"] == v0), None)
            if at is not None:
                c.update(measured=at["measured"], reference=at["expected"], error=at["error"])
                c.update(model_error=at.get("model_error"), step_error=at.get("step_error"))
                c["v0"] = v0
        rows.append(
            [
                m.variant,
                m.scene,
                c["verdict"],
                m.metric,
                f"{c['v0']:g}" if c["v0"] is not None else "all",
                _fmt_v(c["measured"], c["unit"]),
                _fmt_v(c["reference"], c["unit"]),
                _fmt(c["error"]),
                _fmt(c["model_error"]),
                _fmt(c["step_error"]),
                _fmt(c["ratio"]),
                _fmt(c["order"]),
                c["tolerance"],
                m.status,
            ]
        )
    return rows


def _legend_lines(result, show_skipped: bool) -> list[str]:
    """The rule of every metric shown (what is compared with what), then skip reasons."""
    lines, seen = [], set()
    for m in result.metrics:
        if m.status in ("pass", "fail") and getattr(m, "rule", "") and m.metric not in seen:
            seen.add(m.metric)
            lines.append(f"  {m.metric}: {m.rule}")
    if lines:
        lines = [
            "rules (v0 in m/s; error is what the limit bounds; implementation: tolerance = "
            "base + factor x the error of the code's declared scheme (textbook Verlet unless "
            "it declares another) at the same step; delivery: a fixed "
            "tolerance, error = |model + step|, both signed: model = declared law's exact - "
            "asked (recalibrate), step = measured - declared law's exact (refine the step), "
            "over asked):"
        ] + lines
    if show_skipped:
        for m in result.metrics:
            if m.status in ("skip", NA):
                lines.append(
                    f"{_PLAIN_STATUS[m.status]} {m.variant} / {m.scene} / {m.metric}: "
                    f"{m.explanation}"
                )
    return lines


def scorecard_text(result, show_skipped: bool = False) -> str:
    """The scorecard as full-width plain text: summary first, then the details table,
    then one line per failure (what ``hcv bench`` prints when stdout is not a terminal)."""
    lines = _summary_lines(result) + [""]
    rows = [list(_COLUMNS)] + [[*r[:-1], _PLAIN_STATUS[r[-1]]] for r in _rows(result, show_skipped)]
    widths = [max(len(r[i]) for r in rows) for i in range(len(_COLUMNS))]
    right = _RIGHT
    for j, r in enumerate(rows):
        cells = [
            r[i].rjust(widths[i]) if i in right else r[i].ljust(widths[i]) for i in range(len(r))
        ]
        lines.append("  ".join(cells).rstrip())
        if j == 0:
            lines.append("  ".join("-" * w for w in widths))
    lines += _legend_lines(result, show_skipped)
    for m in result.failures:
        lines.append(f"FAIL {m.variant} / {m.scene} / {m.metric}: {m.explanation}")
    if result.interrupted:
        lines.append("interrupted: results so far")
    return "\n".join(lines) + "\n"


def render_scorecard(result, console=None, show_skipped: bool = False) -> None:
    """Print the scorecard: a summary per code (with each metric our reference could
    not decide), then the details, then each failure.

    On a terminal it is a rich table; otherwise (CI logs, pipes) full-width plain
    text (`scorecard_text`), never cut to the console width.
    """
    from rich.console import Console
    from rich.markup import escape
    from rich.table import Table

    console = console or Console()
    if not console.is_terminal:
        console.file.write(scorecard_text(result, show_skipped))
        console.file.flush()
        return
    for line in _summary_lines(result):
        console.print(escape(line), highlight=False, soft_wrap=True)
    table = Table(title="details")
    for col in _COLUMNS:
        table.add_column(
            col,
            justify="right"
            if _COLUMNS.index(col) in _RIGHT
            else ("center" if col == "result" else "left"),
        )
    for r in _rows(result, show_skipped):
        table.add_row(*(escape(x) for x in r[:-1]), _STATUS[r[-1]])
    console.print(table)
    for line in _legend_lines(result, show_skipped):
        console.print(escape(line), highlight=False, soft_wrap=True)
    for m in result.failures:
        console.print(
            f"[bold red]FAIL[/] {escape(m.variant)} / {escape(m.scene)} / {m.metric}: "
            f"{escape(m.explanation)}",
            highlight=False,
            soft_wrap=True,
        )
    if result.interrupted:
        console.print("[bold red]interrupted: results so far[/]")


_SPEED_COLUMNS = ("adapter", "scene", "run", "seconds", "err e", "err t_c", "err q_max")


def _speed_rows(result) -> list[list[str]]:
    rows = []
    for r in result.speed_error:
        run = r["method"] if r.get("steps_per_contact") is None else r["setting"]
        errs = (
            [f"failed: {r['failure']}", "", ""]
            if r.get("failure")
            else [
                _fmt(r.get(k))
                for k in ("err_restitution", "err_contact_time", "err_max_penetration")
            ]
        )
        rows.append([str(r["adapter"]), str(r["scene"]), str(run), _fmt(r.get("seconds")), *errs])
    return rows


def render_speed_error(result, console=None) -> None:
    """Print the speed-against-error rows (rich table, or plain text off a terminal)."""
    from rich.console import Console
    from rich.markup import escape
    from rich.table import Table

    console = console or Console()
    rows = _speed_rows(result)
    if not console.is_terminal:
        allrows = [list(_SPEED_COLUMNS)] + rows
        widths = [max(len(r[i]) for r in allrows) for i in range(len(_SPEED_COLUMNS))]
        lines = ["", "speed against error (middle speed of each scene)"]
        for j, r in enumerate(allrows):
            lines.append(
                "  ".join(
                    r[i].rjust(widths[i]) if i >= 3 else r[i].ljust(widths[i])
                    for i in range(len(r))
                ).rstrip()
            )
            if j == 0:
                lines.append("  ".join("-" * w for w in widths))
        console.file.write("\n".join(lines) + "\n")
        console.file.flush()
        return
    table = Table(title="speed against error (middle speed of each scene)")
    for c in _SPEED_COLUMNS:
        table.add_column(c, justify="right" if c in _SPEED_COLUMNS[3:] else "left")
    for r in rows:
        table.add_row(*(escape(x) for x in r))
    console.print(table)


def scorecard_markdown(result) -> str:
    """The scorecard and the speed table as markdown (for ``hcv report``)."""
    out = [
        f"### Benchmark of `{result.adapter}`",
        "",
        f"{_count_text(result.counts())} "
        f"(commit {result.machine.get('commit') or 'unknown'})."
        + (
            f" {_OURS}: the suite's own reference could not decide the metric "
            "(an internal error, not the code's failure)."
            if result.internal_errors
            else ""
        ),
        "",
        "| adapter | scene | verdict | metric | v0 (m/s) | measured | expected | error | "
        "model err | step err | ratio | order | tolerance | result | why |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for m in result.metrics:
        if m.status in ("skip", NA):
            continue
        why = m.explanation.replace("|", "/") if m.status in ("fail", "error") else ""
        c = metric_columns(result, m)
        out.append(
            f"| {m.variant} | {m.scene} | {c['verdict']} | {m.metric} | "
            f"{_fmt(c['v0']) if c['v0'] is not None else 'all'} | "
            f"{_fmt_v(c['measured'], c['unit'])} | {_fmt_v(c['reference'], c['unit'])} | "
            f"{_fmt(c['error'])} | {_fmt(c['model_error'])} | {_fmt(c['step_error'])} | "
            f"{_fmt(c['ratio'])} | {_fmt(c['order'])} | {m.tolerance} | "
            f"{_OURS if m.status == 'error' else m.status} | {why} |"
        )
    if result.speed_error:
        out += [
            "",
            "| adapter | scene | method | setting | seconds | err e | err t_c | err q_max |",
            "|---|---|---|---|---|---|---|---|",
        ]
        for r in result.speed_error:
            out.append(
                f"| {r['adapter']} | {r['scene']} | {r['method']} | {r['setting']} | "
                f"{_fmt(r.get('seconds'))} | {_fmt(r.get('err_restitution'))} | "
                f"{_fmt(r.get('err_contact_time'))} | "
                f"{_fmt(r.get('err_max_penetration'))} |"
            )
    return "\n".join(out) + "\n"


def write_markdown(result, path) -> None:
    """Write `scorecard_markdown` (atomically, mode of a new file)."""
    atomic_write(path, scorecard_markdown(result))


# Kept importable from here (their home is `reference_impl.bench.scorecard.compare`).
from reference_impl.bench.scorecard.compare import (  # noqa: E402
    json_number,
    plot_speed_error,
    side_by_side,
    side_by_side_markdown,
)

# Public names of the cell formatting, so that the report renders values as the scorecard does.
UNITS = _UNITS
format_value = _fmt
format_with_unit = _fmt_v
