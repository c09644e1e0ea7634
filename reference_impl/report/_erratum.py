"""The referee's erratum: what the paper prints, what the measurements establish instead.

Written from a results dict (``results.json`` of ``hcv report``): for each claim that does
not hold as printed, the printed statement (LaTeX quoted from the paper, with its section
and equation), the corrected statement where the measurements establish one, the decisive
numbers (read from the claim's measurement, never typed) and the commands that reproduce
them; one line for each claim that holds. Each claim module holds its own quote
(``PRINTED``, checked against the .tex by the suite) and its ``corrected()`` text; this
module only formats them.

``python -m reference_impl.report._erratum [RESULTS] [-o OUT]`` writes it from a
results.json; `hcv report` writes ``erratum.md`` and a section of the report.
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

from reference_impl.claims import CLAIMS, Claim, get_claim
from reference_impl.errors import HCVInputError
from reference_impl.report._blocks import UL, H, P
from reference_impl.report._blocks import markdown_lines as _md
from reference_impl.report._schema import read_results
from reference_impl.report._text import markdown_text as _t

__all__ = ["entries", "markdown", "blocks", "plain", "printed", "script_path"]


def _claim(claim_id: str) -> Claim | None:
    """The registered claim of an id in a results dict (None for a claim since removed)."""
    try:
        return get_claim(claim_id)
    except KeyError:
        return None


def printed() -> dict[str, tuple[str, int | None, str]]:
    """claim id -> (where, equation number or None, LaTeX as printed), from each claim module."""
    return {c.id: c.printed for c in CLAIMS if c.printed is not None}


_TEX = [
    (r"\Delta t", "Δt"),
    (r"\frac{dJ}{dE}", "dJ/dE"),
    (r"\pi", "π"),
    (r"\,", " "),
    (r"\Delta", "Δ"),
    (r"\le", "≤"),
    (r"_{\text{safe}}", "_safe"),
    (r"\times 10^{-13}", "× 10^-13"),
    ("$", ""),
]


def plain(tex: str) -> str:
    """The LaTeX of a quote as plain text (the few macros the quotes use)."""
    for a, b in _TEX:
        tex = tex.replace(a, b)
    return re.sub(r"\s+", " ", tex).strip()


def script_path(claim_id: str) -> str:
    """The claim's independent reproduction script, relative to the checkout."""
    return f"reports/repro/{claim_id.replace('-', '_')}.py"


def _commands(c: dict, repro: str | None = None) -> str:
    """How to reproduce a claim; the script is linked only where ``repro`` says it lies
    (``repro_scripts`` of the dict being rendered, set by the writer from the directory the
    pages go to: a report written elsewhere links to no missing file)."""
    files = sorted({t.split("::")[0] for t in c.get("tests", [])})
    name = Path(script_path(c["id"])).name
    link = f", [{name}]({repro}/{name})" if repro else ""
    return (
        f"`python {script_path(c['id'])}` (independent{link}); `python reports/repro/run_all.py` "
        f"(compares with results.json); measurement: `hcv report`"
        + (f", `pytest {' '.join('verification/' + f for f in files)}`" if files else "")
    )


def entries(results: dict) -> list[dict]:
    """One entry per claim: id, verdict, section, printed quote, corrected, numbers, commands."""
    out = []
    for c in results["claims"]:
        e = {
            "id": c["id"],
            "verdict": c["verdict"],
            "section": c["section"],
            "script": script_path(c["id"]),
            "commands": _commands(c, results.get("repro_scripts")),
            "headline": c["headline"],
        }
        if c["verdict"] != "verified":
            claim = _claim(c["id"])
            quote = claim.printed if claim else None
            where, eq, tex = quote or (c["section"], None, c["statement"])
            e["printed"] = f"{where}{f', Eq. ({eq})' if eq else ''}: “{plain(tex)}”"
            fixed = claim.corrected(c["measured"], results) if claim else None
            e["corrected"], e["numbers"] = fixed or ("None established.", c["evidence"])
        out.append(e)
    return out


def blocks(results: dict, level: int = 2) -> list:
    """The erratum as report blocks (heading, one list per claim)."""
    es = entries(results)
    bad = [e for e in es if e["verdict"] != "verified"]
    out = [
        H(level, "Erratum", "erratum"),
        P(
            f"{len(bad)} of {len(es)} claims do not hold as printed. Numbers from the run of "
            f"{results['generated_utc']} ({results['mode']}); each claim's independent script "
            "(numpy, scipy, mpmath only) is named with it."
        ),
    ]
    for e in bad:
        out.append(H(level + 1, f"{e['id']} ({e['section']}): {e['verdict']}"))
        out.append(
            UL(
                [
                    f"Printed: {e['printed']}",
                    f"Corrected: {e['corrected']}",
                    f"Measured: {e['numbers']}",
                    f"Reproduce: {e['commands']}",
                ]
            )
        )
    out.append(H(level + 1, "Claims that hold"))
    out.append(
        UL(
            [
                f"{e['id']} ({e['section']}): verified: {e['headline']}; script `{e['script']}`"
                for e in es
                if e["verdict"] == "verified"
            ]
        )
    )
    return out


def markdown(results: dict) -> str:
    """reports/erratum.md."""

    out = ["# Erratum: " + _t(results["title"].split(": ", 1)[-1]) + "\n"]
    _md(blocks(results, level=2)[1:], out)
    return "\n".join(out) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description="write the erratum from a results.json")
    ap.add_argument("results", nargs="?", default="reports/results.json")
    ap.add_argument("-o", "--out", help="output file (default: stdout)")
    a = ap.parse_args(argv)
    try:  # checked as hcv report --from: the erratum renders only a checked document
        results = read_results(a.results, "erratum of")
    except HCVInputError as exc:
        print(f"erratum: error: {exc}", file=sys.stderr)
        return 2
    results["repro_scripts"] = None  # never a link the document itself names
    if a.out:  # the scripts are linked only when they lie beside the file written
        from reference_impl.report._files import scripts_href

        results["repro_scripts"] = scripts_href(Path(a.out).absolute().parent)
    text = markdown(results)
    if a.out:
        Path(a.out).write_text(text)
    else:
        sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
