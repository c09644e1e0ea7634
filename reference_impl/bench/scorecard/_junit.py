"""The JUnit XML report of a benchmark run (`junit_tree`, `write_junit`).

One testsuite per adapter variant, one testcase per scene x metric (``classname`` =
``hcv.bench.<variant>.<scene>``), failures with the one-line explanation as message and
the details as text, skips with their reason, and an ``<error>`` for a metric our own
reference could not decide (status "error": an internal error, never the code's failure).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

from reference_impl._atomic import atomic_write
from reference_impl.bench.scorecard._cells import _fmt, _fmt_v, metric_columns

__all__ = ["junit_tree", "write_junit"]


def _details(result, m) -> str:
    """Per-speed details of one failed (or undecided) metric, for the JUnit text."""
    c = metric_columns(result, m)
    lines = [m.explanation, f"verdict: {c['verdict']}"]
    if c["measured"] is not None or c["reference"] is not None:
        at = f" at v0 = {c['v0']:g} m/s" if c["v0"] is not None else ""
        lines.append(
            f"measured: {_fmt_v(c['measured'], c['unit']) or '-'}, expected: "
            f"{_fmt_v(c['reference'], c['unit']) or '-'}{at}"
        )
    for key in ("error", "model_error", "step_error", "ratio", "order"):
        if c[key] is not None:
            lines.append(f"{key.replace('_', ' ')}: {_fmt(c[key])}")
    lines.append(f"tolerance: {m.tolerance or '-'}")
    for c in result.contexts:
        if c.variant == m.variant and c.scene == m.scene:
            for r in c.speeds:
                if r.error:
                    lines.append(f"v0 = {r.v0:g} m/s: run failed: {r.error}")
                    if r.stderr:
                        lines.append("stderr:\n" + r.stderr)
            if c.sustained and c.sustained.get("error"):
                lines.append(f"sustained run failed: {c.sustained['error']}")
                if c.sustained.get("stderr"):
                    lines.append("stderr:\n" + c.sustained["stderr"])
    return "\n".join(lines)


def junit_tree(result) -> ET.ElementTree:
    """The JUnit XML tree (testsuites > testsuite per variant > testcase per scene x metric)."""
    root = ET.Element("testsuites", name=f"hcv bench {result.adapter}")
    by_variant: dict[str, list] = {}
    for m in result.metrics:
        by_variant.setdefault(m.variant, []).append(m)
    totals = {"tests": 0, "failures": 0, "errors": 0, "skipped": 0}
    for variant, items in by_variant.items():
        fails = sum(m.status == "fail" for m in items)
        errors = sum(m.status == "error" for m in items)
        skips = sum(m.status in ("skip", "n/a") for m in items)
        suite = ET.SubElement(
            root,
            "testsuite",
            name=variant,
            tests=str(len(items)),
            failures=str(fails),
            errors=str(errors),
            skipped=str(skips),
        )
        for m in items:
            case = ET.SubElement(
                suite,
                "testcase",
                classname=f"hcv.bench.{variant}.{m.scene}",
                name=m.metric,
                time="0",
            )
            if m.status == "fail":
                el = ET.SubElement(case, "failure", message=m.explanation, type="MetricFailed")
                el.text = _details(result, m)
            elif m.status == "error":  # ours: the reference failed, not the code
                el = ET.SubElement(case, "error", message=m.explanation, type="ReferenceError")
                el.text = _details(result, m)
            elif m.status in ("skip", "n/a"):
                ET.SubElement(case, "skipped", message=f"{m.status}: {m.explanation}")
            else:
                c = metric_columns(result, m)
                out = ET.SubElement(case, "system-out")
                out.text = (
                    f"{c['verdict']}: measured {_fmt_v(c['measured'], c['unit']) or '-'}, "
                    f"expected {_fmt_v(c['reference'], c['unit']) or '-'}, "
                    + ", ".join(
                        f"{k.replace('_', ' ')} {_fmt(c[k])}"
                        for k in ("error", "model_error", "step_error", "ratio", "order")
                        if c[k] is not None
                    )
                    + f"; tolerance {m.tolerance or '-'}"
                )
        totals["tests"] += len(items)
        totals["failures"] += fails
        totals["errors"] += errors
        totals["skipped"] += skips
    root.set("tests", str(totals["tests"]))
    root.set("failures", str(totals["failures"]))
    root.set("errors", str(totals["errors"]))
    root.set("skipped", str(totals["skipped"]))
    root.set("time", f"{result.seconds:.3f}")
    return ET.ElementTree(root)


def write_junit(result, path) -> None:
    """Write the JUnit XML report (atomically)."""
    tree = junit_tree(result)
    ET.indent(tree)
    text = ET.tostring(tree.getroot(), encoding="unicode", xml_declaration=True)
    atomic_write(path, text + "\n")
