"""The report's assemblies section (issue 39 section 6): table, figures, linear checks, hook.

The section is rendered from a results document: the committed ``reports/results.json``
with the claim ``sec6-assemblies``'s quick measurement put in and the section's field
(``assemblies``: the quick linear checks, the two figures drawn from the claim's rows).
Fast: the quick claim (a few seconds once compiled) and five linear searches (about a
second).
"""

from __future__ import annotations

import copy
import json
import shutil
from pathlib import Path

import pytest

from reference_impl._format import jsonable
from reference_impl.campaign import _assembly
from reference_impl.claims import sec6_assemblies
from reference_impl.errors import HCVInputError
from reference_impl.report import _render, check_results
from reference_impl.report._assemblies import FIGURES, assemblies_figures, docs_block, rewrite_docs
from verification.assertions import assert_true

ROOT = Path(__file__).resolve().parents[1]
REPORTS = ROOT / "reports"
CLAIM = "report assemblies"
CALL = "assemblies_blocks(results with sec6_assemblies.measure(quick=True))"


@pytest.fixture(scope="module")
def linear():
    return jsonable(_assembly.linear_checks(quick=True))


@pytest.fixture(scope="module")
def doc(tmp_path_factory, linear):
    """(report directory, results document) with the assemblies section."""
    if not (REPORTS / "results.json").is_file():
        pytest.skip("reports/results.json not generated")
    out = tmp_path_factory.mktemp("asm")
    shutil.copytree(REPORTS / "figures", out / "figures")
    r = json.loads((REPORTS / "results.json").read_text())
    measured = jsonable(sec6_assemblies.measure(quick=True).to_dict())["measured"]
    claim = next(c for c in r["claims"] if c["id"] == sec6_assemblies.ID)
    claim["measured"] = measured
    names = assemblies_figures(measured["rows"], out / "figures")
    # a committed report that has the section lists its figures already: once each
    r["figures"] = [f for f in r["figures"] if f not in names] + names
    r["assemblies"] = {
        "claim": sec6_assemblies.ID,
        "linear": linear,
        "figures": dict(zip(("p_fail", "factor"), names, strict=True)),
        "code_advice": None,
    }
    check_results(r, "test document", base=out)
    return out, r


def test_linear_checks_reproduce_two_over_omega_max(linear):
    """Every quick case (chains of the three wall settings, a lattice with and without
    tangential springs) within the issue's 1e-6, the closed form among the references."""
    rows = linear["rows"]
    bad = [(x["case"], x["rel_diff"]) for x in rows if not x["rel_diff"] <= linear["rtol"]]
    consistent = all(
        x["holds"] == (x["rel_diff"] <= linear["rtol"])
        and x["rel_diff"] == abs(x["dt_search"] / x["dt_reference"] - 1.0)
        for x in rows
    )
    assert_true(
        not bad and consistent and any(x["reference"].startswith("closed form") for x in rows),
        got=f"outside {linear['rtol']:g}: {bad}, rows consistent {consistent}",
        should="every case within rtol, holds and rel_diff as computed, a closed-form row",
        claim=CLAIM,
        call="campaign._assembly.linear_checks(quick=True)",
    )


def test_p_fail_curves_are_the_claims_own_quantiles(doc):
    """The figure's curves and the table come from one measurement: the lanes' 5 % point
    (numpy's "lower" quantile: rank floor(0.05 (n - 1))) is a point of the P_fail curve."""
    _, r = doc
    claim = next(c for c in r["claims"] if c["id"] == sec6_assemblies.ID)["measured"]
    n = claim["n_lanes"]
    rank = int(0.05 * (n - 1))
    wrong = []
    for row in claim["rows"]:
        for h, curve in row["p_fail_by_horizon"].items():
            want = row["ratio_by_horizon"][h]["5"]
            got = curve[rank][0] / row["dt_safe"]["paper"] if len(curve) > rank else None
            if got != want or curve[rank][1] != (rank + 1) / n:
                wrong.append((row["case"], h, got, want))
    assert_true(
        not wrong,
        got=f"(case, horizon, curve point / dt_safe, 5 % point) {wrong}",
        should="the P_fail curve through the table's 5 % point at fraction (rank + 1) / n",
        claim=CLAIM,
        call="sec6_assemblies.measure(quick=True) rows",
    )


def test_section_renders_table_figures_and_linear_rows(doc):
    out, r = doc
    md = _render.markdown(r)
    page = _render.html_page(r, out / "figures")
    rows = next(c for c in r["claims"] if c["id"] == sec6_assemblies.ID)["measured"]["rows"]
    section = md.split("## Assemblies")[1].split("\n## ")[0] if "## Assemblies" in md else ""
    missing = [x["case"] for x in rows if f"| {x['case']} |" not in section]
    missing += [x["case"] for x in r["assemblies"]["linear"]["rows"] if x["case"] not in section]
    figs = [f"](figures/{FIGURES[k]})" for k in ("p_fail", "factor")]
    embedded = page.count('<figure><img src="data:image/png;base64,')
    assert_true(
        section
        and not missing
        and all(f in section for f in figs)
        and '<a href="#assemblies">' in page
        and embedded == len(r["figures"]),
        got=f"section {'present' if section else 'absent'}, rows missing {missing}, figures "
        f"linked {[f in section for f in figs]}, {embedded} figures embedded in the HTML of "
        f"{len(r['figures'])} listed",
        should="every claim row and linear case in the section, both figures linked, the nav "
        "anchor, every listed figure embedded",
        claim=CLAIM,
        call=CALL,
    )


# The sentence that introduces the advice table (a stage of the timings table is also
# named "the codes' step advice").
_ADVICE = "The codes' own step advice on the same scenes"


def test_code_advice_hook_is_rendered_only_when_present(doc):
    _, r = doc
    with_rows = copy.deepcopy(r)
    with_rows["assemblies"]["code_advice"] = [
        {"code": "yade", "advice": "PWaveTimeStep", "verdict": "unsafe", "scene": "chain-hertz",
         "dt_advice": 1e-6, "dt_crit": 4e-7, "factor": 0.4, "note": None},
    ]  # fmt: skip
    check_results(with_rows, "test document with code advice")
    shown = _render.markdown(with_rows)
    hidden = _render.markdown(r)
    assert_true(
        "| yade | chain-hertz | PWaveTimeStep |" in shown and _ADVICE not in hidden,
        got=f"row shown {'| yade |' in shown}, advice text without rows {_ADVICE in hidden}",
        should="the row rendered when code_advice has one, nothing when it is null",
        claim=CLAIM,
        call="assemblies_blocks(code_advice)",
    )


@pytest.mark.parametrize(
    "change, where",
    [
        (lambda a, r: a.update(claim="no-such-claim"), "$.assemblies.claim"),
        (lambda a, r: r["figures"].remove(a["figures"]["factor"]), "$.assemblies.figures.factor"),
        (lambda a, r: a["figures"].update(p_fail="../x.png"), "$.assemblies.figures.p_fail"),
        (lambda a, r: a["linear"]["rows"][0].pop("rel_diff"), "$.assemblies.linear.rows[0]"),
    ],
)
def test_a_bad_section_is_refused_in_one_line_naming_the_field(doc, change, where):
    _, r = doc
    bad = copy.deepcopy(r)
    change(bad["assemblies"], bad)
    try:
        check_results(bad, "bad document")
        msg = None
    except HCVInputError as exc:
        msg = str(exc)
    assert_true(
        msg is not None and where in msg and "\n" not in msg,
        got=repr(msg),
        should=f"one line naming {where}",
        claim=CLAIM,
        call="check_results(assemblies changed)",
    )


def test_a_document_without_the_section_renders_without_it(doc):
    """hcv-results/1.1 and older: no assemblies field, no section, no nav entry."""
    out, r = doc
    old = copy.deepcopy(r)
    del old["assemblies"]
    old["schema"] = "hcv-results/1.1"
    check_results(old, "1.1 document")
    md = _render.markdown(old)
    page = _render.html_page(old, out / "figures")
    assert_true(
        "## Assemblies" not in md and "#assemblies" not in page,
        got=f"heading {'## Assemblies' in md}, nav {'#assemblies' in page}",
        should="neither",
        claim=CLAIM,
        call="markdown(results without assemblies)",
    )


def test_docs_block_is_the_committed_reports_section():
    """docs/assemblies.md shows what the committed results.json holds, as `hcv report`
    writes it (no number typed by hand); rewriting it from that file changes nothing."""
    if not (REPORTS / "results.json").is_file():
        pytest.skip("reports/results.json not generated")
    r = json.loads((REPORTS / "results.json").read_text())
    text = (ROOT / "docs" / "assemblies.md").read_text()
    assert_true(
        rewrite_docs(r, text) == text,
        got="docs/assemblies.md's block differs from docs_block(reports/results.json)",
        should="identical (regenerate: hcv report into reports/, or rewrite_docs)",
        claim=CLAIM,
        call="rewrite_docs(reports/results.json, docs/assemblies.md)",
    )


def test_docs_block_of_a_report_with_the_section_links_its_figures(doc):
    _, r = doc
    block = docs_block(r)
    rows = next(c for c in r["claims"] if c["id"] == sec6_assemblies.ID)["measured"]["rows"]
    links = [f"](../reports/figures/{FIGURES[k]})" for k in ("p_fail", "factor")]
    missing = [x["case"] for x in rows if f"| {x['case']} |" not in block]
    assert_true(
        not missing and all(x in block for x in links) and "## Assemblies" not in block,
        got=f"rows missing {missing}, links {[x in block for x in links]}",
        should="every row, both figures linked into reports/figures, no second title",
        claim=CLAIM,
        call="docs_block(results with assemblies)",
    )


def test_the_report_runs_the_advice_of_the_chain_codes_it_is_given():
    """`hcv report --adapter` specs select the codes that run chains, once each, in order;
    the reference adapter and codes without chains select none (no stage)."""
    got = _assembly.advice_codes(["reference", "yade[en,wall]", "liggghts", "yade", "mujoco"])
    assert_true(
        got == ("yade", "liggghts") and _assembly.advice_codes(["reference"]) == (),
        got=f"{got}",
        should="('yade', 'liggghts'), and () for the reference adapter alone",
        claim=CLAIM,
        call="advice_codes(adapters)",
    )


@pytest.mark.liggghts
def test_liggghts_advice_rows_are_valid_report_rows(doc):
    """The study's rows (LIGGGHTS on chains of 2-5 and the two periodic lattices) go into
    results.json as the schema asks and are rendered; Rayleigh safe, Hertz time unsafe on
    every scene (issue 39 section 4)."""
    from reference_impl.adapters.liggghts import liggghts_available

    why = liggghts_available()  # None when installed, else the install line
    if why is not None:
        pytest.skip(why)
    _, r = doc
    rows = _assembly.code_advice(("liggghts",))
    with_rows = copy.deepcopy(r)
    with_rows["assemblies"]["code_advice"] = jsonable(rows)
    check_results(with_rows, "test document with LIGGGHTS's advice")
    shown = _render.markdown(with_rows)
    verdicts = {(x["advice"], x["verdict"]) for x in rows}
    lattice_rows = [x for x in rows if x["scene"].startswith("lattice-")]
    assert_true(
        len(rows) == 12
        and len(lattice_rows) == 4
        and verdicts == {("rayleigh", "safe"), ("hertz", "unsafe")}
        and all(f"| liggghts | {x['scene']} | {x['advice']} |" in shown for x in rows),
        got=f"{len(rows)} rows ({len(lattice_rows)} on lattices), verdicts {sorted(verdicts)}",
        should="12 rows (2 advices x (N = 2..5 and 2 lattices)): rayleigh safe, hertz unsafe, "
        "each rendered",
        claim=CLAIM,
        call="code_advice(('liggghts',))",
    )
