"""The erratum (reference_impl/report/_erratum.py): quotes are the paper's, numbers are the run's."""

from __future__ import annotations

import copy
import json
import re
from pathlib import Path

import pytest

from reference_impl.claims import claim_ids
from reference_impl.report import _erratum

from .assertions import assert_true

ROOT = Path(__file__).resolve().parents[1]
PAPER = ROOT.parent.parent / "shared" / "paper" / "hidden-harmonic-contact.tex"
PAPER = PAPER if PAPER.is_file() else Path("/work/shared/paper/hidden-harmonic-contact.tex")
RESULTS = ROOT / "reports" / "results.json"


def _norm(s: str) -> str:
    return re.sub(r"\s+", " ", s).strip()


@pytest.fixture(scope="module")
def results():
    if not RESULTS.is_file():
        pytest.skip("reports/results.json not generated")
    return json.loads(RESULTS.read_text())


@pytest.mark.parametrize("cid", sorted(_erratum.printed()))
def test_quote_is_in_the_paper_with_its_equation_number(cid):
    if not PAPER.is_file():
        pytest.skip("the paper's .tex is not beside this checkout")
    tex = _norm(PAPER.read_text())
    where, eq, quote = _erratum.printed()[cid]
    pos = tex.find(_norm(quote))
    assert_true(
        pos >= 0,
        got=f"quote {quote!r} not found",
        should="verbatim in the .tex",
        claim=cid,
        call="claims.<module>.PRINTED",
    )
    if eq is not None:
        opened = tex[:pos].count(r"\begin{equation}")
        closed = tex[:pos].count(r"\end{equation}")
        assert_true(
            opened == eq and closed == eq - 1,
            got=f"inside equation {opened} (closed {closed})",
            should=f"inside equation ({eq})",
            claim=cid,
            call="claims.<module>.PRINTED",
        )


def test_every_claim_has_an_entry_with_its_script(results):
    es = {e["id"]: e for e in _erratum.entries(results)}
    assert_true(
        set(es) == set(claim_ids()),
        got=sorted(es),
        should="every claim",
        claim="all",
        call="_erratum.entries",
    )
    for cid, e in es.items():
        assert_true(
            (ROOT / e["script"]).is_file(),
            got=f"{e['script']} missing",
            should="an existing script",
            claim=cid,
            call="_erratum.entries",
        )
        if e["verdict"] != "verified":
            for key in ("printed", "corrected", "numbers", "commands"):
                assert_true(
                    bool(e.get(key)),
                    got=f"no {key}",
                    should=f"a {key} line",
                    claim=cid,
                    call="_erratum.entries",
                )


def test_numbers_come_from_the_measurement(results):
    """Changing a measured number changes the erratum, and a verdict flip moves the claim."""
    r = copy.deepcopy(results)
    t1 = next(c for c in r["claims"] if c["id"] == "table1")
    cell = t1["measured"]["rows"][1]["max_force"]
    cell["computed_rounded"] = "10.999999"
    sec6 = next(c for c in r["claims"] if c["id"] == "sec6-dt-safe-bound")
    sec6["measured"]["worst_runaway"]["ratio"] = 0.123456
    thm2 = next(c for c in r["claims"] if c["id"] == "thm2-harmonic")
    thm2["verdict"], thm2["evidence"] = "refuted", "synthetic"
    text = _erratum.markdown(r)
    for needle in ("10.999999", "0.1235 Δt_safe", "### thm2-harmonic"):
        assert_true(
            needle in text,
            got=f"{needle!r} absent",
            should="in the erratum",
            claim="erratum",
            call="_erratum.markdown(modified results)",
        )


def test_scripts_are_linked_only_where_they_are(results, tmp_path):
    """The erratum links repro/<claim>.py only when the report's directory holds them
    (`scripts_href`): the checkout's reports/, not a report written elsewhere."""
    from reference_impl.report._files import scripts_href

    assert_true(
        scripts_href(tmp_path) is None and scripts_href(ROOT / "reports") == "repro",
        got=f"{scripts_href(tmp_path)!r}, {scripts_href(ROOT / 'reports')!r}",
        should="None for an empty directory, 'repro' for reports/",
        claim="erratum",
        call="scripts_href",
    )
    elsewhere = _erratum.markdown({**results, "repro_scripts": None})
    here = _erratum.markdown({**results, "repro_scripts": "repro"})
    link = re.compile(r"\]\((repro/[^)]+)\)")
    targets, stray = link.findall(here), link.findall(elsewhere)
    assert_true(
        not stray and targets and all((ROOT / "reports" / t).is_file() for t in targets),
        got=f"links elsewhere: {stray[:3]}; here: {targets[:3]}",
        should="no repro link elsewhere; existing scripts in reports/",
        claim="erratum",
        call="_erratum.markdown",
    )


def test_committed_erratum_is_generated_from_committed_results(results):
    from reference_impl.report._files import scripts_href

    committed = ROOT / "reports" / "erratum.md"
    # As `python -m reference_impl.report._erratum reports/results.json -o reports/erratum.md`
    # writes it: the scripts beside it are linked.
    expected = _erratum.markdown({**results, "repro_scripts": scripts_href(committed.parent)})
    assert_true(
        committed.is_file() and committed.read_text() == expected,
        got="reports/erratum.md differs from the generator's output",
        should="python -m reference_impl.report._erratum reports/results.json "
        "-o reports/erratum.md",
        claim="erratum",
        call="reports/erratum.md",
    )


def test_each_claim_not_verified_holds_its_quote_and_correction(results):
    """Issue 30: a claim's printed statement and corrected text live in its own module
    (``PRINTED``, ``corrected()``); the erratum only formats them."""
    from reference_impl.claims import get_claim

    for c in results["claims"]:
        if c["verdict"] == "verified":
            continue
        claim = get_claim(c["id"])
        fixed = claim.corrected(c["measured"], results)
        assert_true(
            claim.printed is not None and fixed is not None and all(fixed),
            got=f"PRINTED {claim.printed!r}, corrected() {fixed!r}",
            should="both defined in the claim's module",
            claim=c["id"],
            call=f"claims.{claim.module}.PRINTED / corrected()",
        )
