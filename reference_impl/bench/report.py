"""Outputs of the benchmark: JSON, JUnit XML, the rich scorecard, markdown and the plot.

* JSON (`write_json`): schema ``hcv-bench/1``, with machine and commit info,
  the tolerances, every metric, the per-speed records (runs, implemented laws,
  exact references, critical steps) and the speed-against-error rows. Written
  atomically (temporary file, then rename), so a reader never sees half a file,
  with the mode of a new file (0666 less the umask, not mkstemp's 0600).
* JUnit XML (`write_junit`): one testsuite per adapter variant, one testcase per
  scene x metric (``classname`` = ``hcv.bench.<variant>.<scene>``), failures
  with the one-line explanation as message and the details as text, skips
  with their reason, and an ``<error>`` for a metric our own reference could not
  decide (status "error": an internal error, never the code's failure).
* `render_scorecard`: the scorecard as a rich table (what ``hcv bench`` prints);
  `render_speed_error`: the speed-against-error table.
* `scorecard_markdown`: for ``hcv report``; `side_by_side` and `plot_speed_error`
  (home: `reference_impl.bench.compare`, re-exported here) as well.

Metric statuses: "pass", "fail", "skip" and "error" (the suite's reference
failed). Every output above knows all four (`STATUSES`).

Here: the scorecard for people (plain text, rich, markdown). The JSON and JUnit
documents are written by `reference_impl.bench._json` and `reference_impl.bench._junit`,
the compared values of a metric read by `reference_impl.bench._cells.metric_columns`;
every one of their public names is importable from here.
"""

from __future__ import annotations

import math

from reference_impl._atomic import atomic_write
from reference_impl.bench._cells import (
    _OURS,
    _PLAIN_STATUS,
    _UNITS,
    _fmt,
    _fmt_v,
    metric_columns,
)
from reference_impl.bench._json import SCHEMA, machine_info, result_to_dict, write_json
from reference_impl.bench._junit import junit_tree, write_junit

__all__ = [
    "SCHEMA",
    "STATUSES",
    "UNITS",
    "format_value",
    "format_with_unit",
    "json_number",
    "junit_tree",
    "machine_info",
    "metric_columns",
    "plot_speed_error",
    "render_scorecard",
    "render_speed_error",
    "result_to_dict",
    "scorecard_markdown",
    "scorecard_text",
    "side_by_side",
    "side_by_side_markdown",
    "write_json",
    "write_junit",
    "write_markdown",
]

# Every metric status, in the order the summaries list them.
STATUSES = ("pass", "fail", "skip", "error")


_STATUS = {
    "pass": "[green]pass[/]",
    "fail": "[bold red]FAIL[/]",
    "skip": "[dim]skip[/]",
    "error": f"[bold magenta]{_OURS}[/]",
}


def _count_text(counts: dict) -> str:
    """Counts as text, e.g. "3 pass, 1 fail, 2 skipped" (+ ", 1 ERROR (ours)")."""
    text = f"{counts.get('pass', 0)} pass, {counts.get('fail', 0)} fail, {counts.get('skip', 0)} skipped"
    if counts.get("error"):
        text += f", {counts['error']} {_OURS}"
    return text


def _summary_lines(result) -> list[str]:
    """Per code: pass / fail counts, then each failing metric with measured vs expected,
    then each metric our reference could not decide (status "error")."""
    lines = [
        f"hcv bench {result.adapter}: {_count_text(result.counts())}"
        + (" (interrupted)" if result.interrupted else "")
    ]
    by_variant: dict[str, list] = {}
    for m in result.metrics:
        by_variant.setdefault(m.variant, []).append(m)
    for variant, items in by_variant.items():
        counts = {s: sum(m.status == s for m in items) for s in STATUSES}
        lines.append(f"  {variant}: {_count_text(counts)}")
        for m in items:
            if m.status == "error":
                lines.append(f"    {_OURS} {m.scene} / {m.metric}: {m.explanation}")
            if m.status != "fail":
                continue
            c = metric_columns(result, m)
            at = f" at v0 = {c['v0']:g} m/s" if c["v0"] is not None else ""
            lines.append(
                f"    FAIL {m.scene} / {m.metric}: measured "
                f"{_fmt_v(c['measured'], c['unit']) or '-'}, expected "
                f"{_fmt_v(c['reference'], c['unit']) or '-'}{at}; error "
                f"{_fmt(c['error']) or '-'}, tolerance {c['tolerance'] or '-'}"
            )
    return lines


_COLUMNS = (
    "adapter", "scene", "metric", "v0", "measured", "reference", "error", "tolerance", "result"
)  # fmt: skip
_RIGHT = {3, 4, 5, 6}


def _common_speeds(result) -> dict:
    """(scene, metric) -> the speed every code's row shows: the worst over the codes.

    Per code, a metric reports its own worst speed; with several codes (variants) on
    one scene, every row of a metric is read at one speed so that they compare side by
    side (each code's own worst speed is in its FAIL line).
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
        if m.status == "skip" and not show_skipped:
            continue
        c = metric_columns(result, m)
        v0 = common.get((m.scene, m.metric))
        if v0 is not None and v0 != c["v0"]:
            at = next((r for r in m.per_v0 if r["v0"] == v0), None)
            if at is not None:
                c.update(measured=at["measured"], reference=at["expected"], error=at["error"])
                c["v0"] = v0
        rows.append(
            [
                m.variant,
                m.scene,
                m.metric,
                f"{c['v0']:g}" if c["v0"] is not None else "all",
                _fmt_v(c["measured"], c["unit"]),
                _fmt_v(c["reference"], c["unit"]),
                _fmt(c["error"]),
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
            "rules (v0 in m/s; error is what the limit bounds; tolerance = base + factor x "
            "textbook Verlet's error at the same step):"
        ] + lines
    if show_skipped:
        for m in result.metrics:
            if m.status == "skip":
                lines.append(f"skip {m.variant} / {m.scene} / {m.metric}: {m.explanation}")
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
            if col in ("v0", "measured", "reference", "error")
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
        "| adapter | scene | metric | v0 (m/s) | measured | reference | error | tolerance | result | why |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for m in result.metrics:
        if m.status == "skip":
            continue
        why = m.explanation.replace("|", "/") if m.status in ("fail", "error") else ""
        c = metric_columns(result, m)
        out.append(
            f"| {m.variant} | {m.scene} | {m.metric} | "
            f"{_fmt(c['v0']) if c['v0'] is not None else 'all'} | "
            f"{_fmt_v(c['measured'], c['unit'])} | {_fmt_v(c['reference'], c['unit'])} | "
            f"{_fmt(c['error'])} | {m.tolerance} | {_OURS if m.status == 'error' else m.status} | "
            f"{why} |"
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


# Kept importable from here (their home is `reference_impl.bench.compare`).
from reference_impl.bench.compare import (  # noqa: E402
    json_number,
    plot_speed_error,
    side_by_side,
    side_by_side_markdown,
)

# Public names of the cell formatting, so that the report renders values as the scorecard does.
UNITS = _UNITS
format_value = _fmt
format_with_unit = _fmt_v
