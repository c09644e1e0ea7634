"""Every figure the README and the site state has one home (issue 41, section 2).

A stated figure is a number followed by a unit of time or size (s, min, ms, µs, MB) in
README.md or docs/*.md, outside fenced code and outside a generated block (``<!--
NAME:start -->`` ... ``<!-- NAME:end -->``, rewritten from a record with its commit,
load and cache state). Outside those, a figure is either no measurement (a limit, a
default, a goal, a physical quantity of an example: `_NOT_MEASURED`, each with what it
is) or a measurement still typed by hand (`_TO_MOVE`, each naming the record that
should generate it: the rest of issue 41 section 2). A new figure in neither list
fails, and so does an entry no page states any more (the lists only shrink).
"""

from __future__ import annotations

import re
from pathlib import Path

from verification.assertions import assert_true

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
_BLOCK = re.compile(r"<!-- ([\w-]+):start -->.*?<!-- \1:end -->", re.S)
_FENCE = re.compile(r"```.*?```", re.S)
# A number (a range too: 1.2–1.5 s) followed by its unit; not part of a word or a power.
FIGURE = re.compile(
    r"(?<![\w.^*-])\d+(?:[.,]\d+)?(?:\s?[–-]\s?\d+(?:\.\d+)?)?\s?(?:s|min|MB|µs|ms)\b"
)

# (page, figure as written): what it is. Not measurements: nothing to re-measure.
_NOT_MEASURED = {
    ("adapter-protocol.md", "5 s"): "the grace period before an adapter is killed (code)",
    ("adapter-protocol.md", "60 s"): "the default run timeout (tolerances.toml)",
    ("getting-started.md", "35 s"): "an example of a progress line's form",
    ("getting-started.md", "256 MB"): "HCV_CACHE_MAX_MB's default",
    ("getting-started.md", "64 MB"): "the free-space floor of the cache",
    ("scenes.md", "1.26966 s"): "a solved damping strength (s/m), not a time",
    ("performance.md", "1 s"): "issue 38's goal for hcv solve's CPU time, not a measurement",
    ("scenes.md", "2221 s"): "a solved damping strength of an example law",
    ("scenes.md", "20 s"): "the strength A of an example law",
    ("scenes.md", "293 s"): "the contact time of that example (a physical result)",
    ("scenes.md", "1 MB"): "the size limit of a scene file",
    ("sweeps.md", "10 s"): "the scheduler's connect timeout",
    ("performance.md", "8 µs"): "issue 27's goal",
}

# (page, figure as written): the record that should generate it. Measured by hand, left
# for a generated block (issue 41 section 2, not done in its first pass).
_TO_MOVE = {
    ("README.md", "15 s"): "the smoke command's wall time (a bench_startup row)",
    ("README.md", "26 s"): "the smoke command's CPU time (a bench_startup row)",
    ("getting-started.md", "9 s"): "hcv report --from's wall time (a bench_startup row)",
    ("getting-started.md", "1.8 s"): "hcv report --from's CPU time (a bench_startup row)",
    ("getting-started.md", "0.1 s"): "scipy.special's import (bench_startup)",
    ("getting-started.md", "1-3 ms"): "the cache key's cost (bench_startup)",
    ("getting-started.md", "0.5 s"): "numba's import (bench_startup)",
    ("adapter-protocol.md", "8.2 s"): "the YADE gate (a bench_codes record: none committed)",
    ("adapter-protocol.md", "7.4 s"): "a YADE variant's gate (bench_codes)",
    ("adapter-protocol.md", "240 s"): "a one-shot YADE gate (bench_codes)",
    ("adapter-protocol.md", "4.0 s"): "a one-shot YADE run (bench_codes)",
    ("adapter-protocol.md", "25 s"): "the LIGGGHTS gate (bench_codes; 78 s measured at a similar load)",
    ("adapter-protocol.md", "0.6 s"): "a LIGGGHTS start (bench_codes)",
    ("adapter-protocol.md", "155 s"): "a one-shot LIGGGHTS gate (bench_codes)",
    ("adapter-protocol.md", "654 s"): "issue 28's one-shot YADE gate (its own measurement)",
    ("benchmarking.md", "8 s"): "the YADE gate (bench_codes)",
    ("benchmarking.md", "4 s"): "a one-shot YADE run (bench_codes)",
    ("benchmarking.md", "25 s"): "the LIGGGHTS gate (bench_codes)",
    ("benchmarking.md", "155 s"): "a one-shot LIGGGHTS gate (bench_codes)",
    ("verdicts.md", "10 s"): "run_all.py's CPU time (no record)",
    ("verdicts.md", "6 s"): "run_all.py's wall time at load 5 (no record)",
    ("verdicts.md", "40 s"): "run_all.py's wall time at load 12 (no record)",
    **{
        ("performance.md", f): "reports/bench/sweep.json or device_scaling.json"
        for f in (
            "0.2–8 ms", "0.17 s", "83 s", "45 s", "0.39 ms", "6.4 ms", "5 ms", "1.2–1.5 s",
            "3 s", "1.5 s", "170 ms", "42 s", "22 s", "136.6 s", "71.4 s", "43.7 s",
            "18.5 s", "13.5 s", "11.1 s", "0.10–0.13 µs", "0.3 s", "6 ms",
        )
    },
}  # fmt: skip


def stated_figures(text: str) -> list[str]:
    """The figures ``text`` states outside fenced code and generated blocks."""
    text = _FENCE.sub("", _BLOCK.sub("", text))
    return [" ".join(m.group(0).split()) for m in FIGURE.finditer(text)]


def _found() -> set[tuple[str, str]]:
    return {(p.name, f) for p in PAGES for f in stated_figures(p.read_text())}


def test_every_stated_figure_has_a_home():
    homeless = sorted(_found() - set(_NOT_MEASURED) - set(_TO_MOVE))
    assert_true(
        not homeless,
        got=f"figures outside a generated block: {homeless}",
        should="none: put a measured figure in a generated block (its record's commit, "
        "load and cache state beside it), or list a limit, default or goal in _NOT_MEASURED",
        claim="docs",
        call="stated_figures(README.md, docs/*.md)",
    )


def test_the_lists_name_only_figures_still_stated():
    gone = sorted((set(_NOT_MEASURED) | set(_TO_MOVE)) - _found())
    assert_true(
        not gone,
        got=f"listed but no longer stated: {gone}",
        should="each entry of _NOT_MEASURED and _TO_MOVE stated on its page (drop the rest)",
        claim="docs",
        call="test_docs_figures lists",
    )


def test_the_scan_finds_figures_and_skips_blocks_and_code():
    text = (
        "The job took 104 s wall (1.33 MB); a range 1.2–1.5 s; q**2.5 s is not one.\n"
        "<!-- x:start -->\n220 s\n<!-- x:end -->\n```bash\nsleep 5 s\n```\n8 µs, 3 min."
    )
    got = stated_figures(text)
    assert_true(
        got == ["104 s", "1.33 MB", "1.2–1.5 s", "8 µs", "3 min"],
        got=str(got),
        should="['104 s', '1.33 MB', '1.2–1.5 s', '8 µs', '3 min']",
        claim="docs",
        call="stated_figures(a planted text)",
    )
