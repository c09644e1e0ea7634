"""The README's verdict table, generated from a report's results.json.

``python -m reference_impl.report.readme_table [--results reports/results.json]
[--readme README.md] [--check]`` rewrites only the block between
``<!-- verdicts:start -->`` and ``<!-- verdicts:end -->`` of the README with one
row per claim of results.json (id, section, verdict, headline). ``--check``
writes nothing and exits 1 when the block differs from what results.json gives.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from ..errors import HCVInputError

__all__ = ["START", "END", "verdict_table", "readme_block", "rewrite_readme"]

START = "<!-- verdicts:start -->"
END = "<!-- verdicts:end -->"
ROOT = Path(__file__).resolve().parents[2]


def _cell(text: str) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def verdict_table(results: dict) -> str:
    """Markdown table: claim | section | verdict | in one line (refuted in bold)."""
    lines = ["| claim | section | verdict | in one line (measured) |", "|---|---|---|---|"]
    for c in results["claims"]:
        verdict = f"**{c['verdict']}**" if c["verdict"] != "verified" else c["verdict"]
        headline = c.get("headline") or c["evidence"].split(";")[0]
        lines.append(f"| {c['id']} | {_cell(c['section'])} | {verdict} | {_cell(headline)} |")
    env = results.get("environment", {})
    commit = (env.get("git_commit") or "unknown")[:12]
    dirty = " (uncommitted changes)" if env.get("git_dirty") else ""
    lines += [
        "",
        f"Generated from `reports/results.json` ({results.get('mode', '?')} run of "
        f"{results.get('generated_utc', '?')}, commit {commit}{dirty}) by "
        f"`python -m reference_impl.report.readme_table`.",
    ]
    return "\n".join(lines)


def readme_block(readme_text: str) -> str:
    """The text between the markers (HCVInputError when they are missing or out of order)."""
    i, j = readme_text.find(START), readme_text.find(END)
    if i < 0 or j < 0 or j < i:
        raise HCVInputError(f"README has no {START} ... {END} block")
    return readme_text[i + len(START) : j].strip("\n")


def rewrite_readme(results: dict, readme_text: str) -> str:
    """The README with only its verdict block replaced."""
    readme_block(readme_text)  # markers present
    i, j = readme_text.find(START), readme_text.find(END)
    return readme_text[: i + len(START)] + "\n" + verdict_table(results) + "\n" + readme_text[j:]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m reference_impl.report.readme_table", description=__doc__.splitlines()[0]
    )
    ap.add_argument("--results", default=str(ROOT / "reports" / "results.json"))
    ap.add_argument("--readme", default=str(ROOT / "README.md"))
    ap.add_argument("--check", action="store_true", help="write nothing; exit 1 if out of date")
    args = ap.parse_args(argv)
    try:
        results = json.loads(Path(args.results).read_text())
        readme = Path(args.readme).read_text()
        new = rewrite_readme(results, readme)
    except (OSError, ValueError, KeyError, HCVInputError) as exc:
        print(f"readme_table: error: {exc}", file=sys.stderr)
        return 2
    if args.check:
        if new != readme:
            print(
                f"readme_table: {args.readme} verdict block differs from {args.results}",
                file=sys.stderr,
            )
            return 1
        return 0
    if new != readme:
        Path(args.readme).write_text(new)
    return 0


if __name__ == "__main__":
    sys.exit(main())
