"""The assemblies claim's long-horizon record (issue 39 section 3): measured, read, merged.

The record ``reports/assemblies_1e6.json`` is written by
`reference_impl.campaign.assembly_long` (minutes of CPU) and read by the claim
``sec6-assemblies``. Here: two of its lanes are recomputed through the campaign's own
group function and must equal the record's bit for bit (the record is measured, not
typed in); the committed record is accepted whole; a tampered record (every way below)
is ignored with one line and the claim falls back to its own horizons; the merge
computes ``holds`` and ``horizon_dependent`` over the three horizons (synthetic record).
Fast: two lanes of a two-body chain at 1e6 steps (~1 s CPU each), the rest is JSON.
"""

from __future__ import annotations

import copy
import json
import math

import numpy as np
import pytest

from reference_impl._format import jsonable
from reference_impl.assembly.search import reference_step
from reference_impl.campaign import assembly_long
from reference_impl.claims import _assembly_record as rec_mod
from reference_impl.claims import sec6_assemblies as claim_mod
from reference_impl.errors import HCVInputError
from reference_impl.report._assemblies import assemblies_blocks
from reference_impl.report._blocks import markdown_lines
from reference_impl.report._files import swap_in
from verification.assertions import assert_true

CLAIM = "assemblies 1e6 record"
RECORD = rec_mod.RECORD_PATH
# The cheapest counted case: two spheres between two walls (~1 s CPU per lane at 1e6).
CHEAP = "chain N=2, walls both"
N = claim_mod.N_LANES


def _expected_full() -> dict:
    """The claim's cases as `read_record` checks them (shape and Delta t_safe, s)."""
    out = {}
    for label, d, z, asm in claim_mod.cases():
        _, safe, _ = reference_step(claim_mod.case_model(asm))
        out[label] = {"n_bodies": asm.n_bodies, "n_contacts": asm.n_contacts, "dim": d,
                      "coordination": z, "dt_safe": safe["paper"]}  # fmt: skip
    return out


@pytest.fixture(scope="module")
def committed():
    assert_true(
        RECORD.is_file(),
        got=f"no file {RECORD}",
        should="the committed record (python -m reference_impl.campaign.assembly_long)",
        claim=CLAIM,
        call="reports/assemblies_1e6.json",
    )
    return json.loads(RECORD.read_text())


# Lanes 1 and N - 1, not lane 0: the group holding lane 0 also runs the claim's cage
# check over the whole 1e6 steps (~26 s); a perturbed lane alone takes ~1.5 s and shows
# the record is the search's output as well.
@pytest.mark.parametrize("first", [1, N - 1])
def test_record_lanes_are_the_claims_search_bit_for_bit(committed, first):
    """Lanes 1 and the last lane of the two-body chain, searched again through the
    campaign's group function (the claim's model, grid, criterion), equal the record."""
    case = next(c for c in committed["cases"] if c["case"] == CHEAP)
    got = assembly_long.run_group((CHEAP, first, 1, committed["horizon"]))
    want = case["dt_crit"][first], case["dt_stable"][first]
    assert_true(
        (got["dt_crit"][0], got["dt_stable"][0]) == want,
        got=f"lane {first}: dt_crit, dt_stable {got['dt_crit'][0]!r}, {got['dt_stable'][0]!r}",
        should=f"the record's {want[0]!r}, {want[1]!r} bit for bit",
        claim=CLAIM,
        call=f"assembly_long.run_group(({CHEAP!r}, {first}, 1, {committed['horizon']}))",
    )


def test_committed_record_is_accepted_whole(committed):
    """The claim reads the committed record without a note and merges every case it ran;
    the record leaves out the claim's uncounted layers, with a reason."""
    record, why = rec_mod.read_record(RECORD, claim_mod.record_settings(), _expected_full())
    ran = sorted(c["case"] for c in committed["cases"])
    left = {x["case"] for x in committed["left_out"]}
    assert_true(
        why is None
        and sorted(record["cases"]) == ran
        and set(assembly_long.LEFT_OUT) <= left
        and set(ran) | left == set(_expected_full()),
        got=f"note {why!r}, cases {ran}, left out {sorted(left)}",
        should="no note, every counted case run or left out with a reason, the square and "
        "honeycomb layers left out",
        claim=CLAIM,
        call="read_record(RECORD_PATH, record_settings(), the claim's cases)",
    )


# --- a synthetic record: two chains, the second left out ------------------------------
_SAFE = 1.0e-6  # s, Delta t_safe of the synthetic cases
_SHAPES = {
    CHEAP: {"n_bodies": 2, "n_contacts": 3, "dim": 1, "coordination": 2.0},
    "chain N=5, walls both": {"n_bodies": 5, "n_contacts": 6, "dim": 1, "coordination": 2.0},
}
_EXPECTED = {k: {**v, "dt_safe": _SAFE} for k, v in _SHAPES.items()}


def _lanes(lo: float, hi: float) -> list[float]:
    """N distinct steps (s) from lo to hi Delta t_safe, out of order (the record's order is
    the lanes', not sorted)."""
    xs = [float(x) for x in np.linspace(lo, hi, N) * _SAFE]
    return xs[1::2] + xs[0::2]


def _synthetic(lo: float = 0.90, hi: float = 1.05) -> dict:
    crit = _lanes(lo, hi)
    s = sorted(crit)
    # numpy's "lower" quantile of N values: rank floor(p (N - 1)), written out here
    qs = {p: s[math.floor(int(p) / 100 * (N - 1))] for p in ("5", "50", "95")}
    case = {
        "case": CHEAP,
        **_SHAPES[CHEAP],
        "dt_safe": {"paper": _SAFE, "reduced": 1.1 * _SAFE, "one_contact": 0.9 * _SAFE},
        "dt_crit": crit,
        "dt_stable": [x * 0.999 for x in crit],
        "evidence": ["confirmed"] * N,
        "quantiles": qs,
        "q_run": 2e-5,
        "contact_updates": 123,
        "dt_tangent": 0.5 * _SAFE,
        "cage_fraction": 0.0,
        "cpu_s": 1.0,
    }
    return {
        "schema": rec_mod.SCHEMA,
        "claim": claim_mod.ID,
        "horizon": rec_mod.LONG_HORIZON,
        "date": "2026-01-01T00:00:00Z",
        "commit": "0123456789abcdef",
        "git_dirty": False,
        "settings": claim_mod.record_settings(),
        "left_out": [{"case": "chain N=5, walls both", "why": "not run (time)"}],
        "cases": [case],
    }


def _write(tmp_path, data) -> object:
    path = tmp_path / "assemblies_1e6.json"
    path.write_text(data if isinstance(data, str) else json.dumps(data))
    return path


def _set(path: str, value):
    """A tampering: set the field at the dotted ``path`` (list indices as numbers)."""

    def change(d):
        keys = path.split(".")
        obj = d
        for k in keys[:-1]:
            obj = obj[int(k)] if isinstance(obj, list) else obj[k]
        last = keys[-1]
        if isinstance(obj, list):
            obj[int(last)] = value
        else:
            obj[last] = value
        return d

    return change


def _drop_lane(d):
    d["cases"][0]["dt_crit"].pop()
    return d


def _twice(d):
    d["cases"].append(copy.deepcopy(d["cases"][0]))
    return d


def _grid(d):
    d["settings"]["grid"]["resolution"] = 1e-3
    return d


def _potential(d):
    d["settings"]["potential"]["k"] *= 1.01
    return d


def _criterion(d):
    d["settings"]["criterion"]["factor"] = 10.0
    return d


# (name, tampering of the synthetic record or the file's text, words the note must hold)
_TAMPERED = [
    ("NaN lane", lambda d: json.dumps(d).replace(repr(d["cases"][0]["dt_crit"][3]), "NaN"), "NaN"),
    ("Infinity", lambda d: json.dumps(d).replace(repr(d["cases"][0]["dt_crit"][0]), "Infinity"),
     "Infinity"),
    ("string for a number", _set("cases.0.dt_crit.3", "1e-6"), "not a number"),
    ("string for dt_safe", _set("cases.0.dt_safe.paper", "1e-6"), "not a number"),
    ("null lane", _set("cases.0.dt_crit.5", None), "not a number"),
    ("negative lane", _set("cases.0.dt_crit.5", -1e-6), "should be finite and > 0"),
    ("zero lane", _set("cases.0.dt_crit.5", 0.0), "should be finite and > 0"),
    ("huge integer", _set("cases.0.dt_crit.5", 10**400), "not a finite float"),
    ("bool for a count", _set("cases.0.n_bodies", True), "n_bodies"),
    ("wrong lanes", _drop_lane, f"{N - 1} lanes, should be {N}"),
    ("wrong lane count setting", _set("settings.n_lanes", 16), "settings.n_lanes"),
    ("wrong grid", _grid, "settings.grid"),
    ("wrong criterion", _criterion, "settings.criterion"),
    ("wrong potential", _potential, "settings.potential"),
    ("wrong mass", _set("settings.mass", 4.0e-3), "settings.mass"),
    ("wrong version", _set("schema", "hcv-assemblies-long/2"), "schema"),
    ("wrong horizon", _set("horizon", 100_000), "horizon is 100000"),
    ("unknown case", _set("cases.0.case", "chain N=3, walls both"), "unknown case"),
    ("another shape", _set("cases.0.n_contacts", 4), "n_contacts"),
    ("another dt_safe", _set("cases.0.dt_safe.paper", 1.001 * _SAFE), "dt_safe"),
    ("stable above failing", _set("cases.0.dt_stable.2", 2.0 * _SAFE), "not below"),
    ("quantile not the lanes'", _set("cases.0.quantiles.5", 0.5 * _SAFE), "not its lanes'"),
    ("unknown evidence", _set("cases.0.evidence.0", None), "evidence"),
    ("case neither run nor left out", _set("left_out", []), "neither in the record"),
    ("case twice", _twice, "twice"),
    ("not an object", lambda d: "[1, 2]", "not an object"),
    ("not JSON", lambda d: json.dumps(d)[:-10], "not JSON"),
    ("too large", lambda d: " " * (rec_mod._MAX_BYTES + 1) + json.dumps(d), "bytes, more than"),
]  # fmt: skip


def test_synthetic_record_is_accepted(tmp_path):
    """The base of the tamperings below is itself a valid record (else they prove nothing)."""
    record, why = rec_mod.read_record(
        _write(tmp_path, _synthetic()), claim_mod.record_settings(), _EXPECTED
    )
    assert_true(
        why is None and list(record["cases"]) == [CHEAP],
        got=f"note {why!r}",
        should="accepted, one case",
        claim=CLAIM,
        call="read_record(synthetic record)",
    )


@pytest.mark.parametrize("name, tamper, words", _TAMPERED, ids=[t[0] for t in _TAMPERED])
def test_tampered_record_is_ignored_with_one_line(tmp_path, name, tamper, words):
    """Ignored, never a traceback: one line naming what is wrong; the rows fall back to the
    claim's own horizons, unchanged, and the evidence says why."""
    path = _write(tmp_path, tamper(_synthetic()))
    record, why = rec_mod.read_record(path, claim_mod.record_settings(), _EXPECTED)
    rows = _rows()
    merged, long = claim_mod.merge_record(rows, record, why)
    m = claim_mod.measurement_from_rows(merged, claim_mod.FULL_HORIZONS, long)
    note = f"1e6 record ignored: {why}"
    assert_true(
        record is None
        and isinstance(why, str)
        and "\n" not in why
        and words in why
        and merged == rows
        and m.evidence.endswith(note)
        and m.figures["horizons"] == list(claim_mod.FULL_HORIZONS),
        got=f"record {'read' if record else 'ignored'}, note {why!r}, rows "
        f"{'unchanged' if merged == rows else 'changed'}, horizons {m.figures['horizons']}",
        should=f"ignored with one line holding {words!r}, the rows and horizons as they were, "
        "the note at the end of the evidence",
        claim=CLAIM,
        call=f"read_record + merge_record ({name})",
    )


def test_missing_record_is_ignored_with_one_line(tmp_path):
    record, why = rec_mod.read_record(
        tmp_path / "absent.json", claim_mod.record_settings(), _EXPECTED
    )
    _, long = claim_mod.merge_record(_rows(), record, why)
    assert_true(
        record is None and long["note"] == "1e6 record ignored: absent.json not found",
        got=f"note {long['note']!r}",
        should="'1e6 record ignored: absent.json not found'",
        claim=CLAIM,
        call="read_record(a missing file)",
    )


def _row(label: str, q4: tuple, q5: tuple) -> dict:
    """A claim row at 1e4 and 1e5 steps with the given 5 / 50 / 95 % points (units of
    Delta t_safe), as `sec6_assemblies._row` writes it."""
    byh = {"10000": dict(zip(("5", "50", "95"), q4, strict=True)),
           "100000": dict(zip(("5", "50", "95"), q5, strict=True))}  # fmt: skip
    return {
        "case": label,
        **_SHAPES[label],
        "dt_safe": {"paper": _SAFE, "reduced": 1.1 * _SAFE, "one_contact": 0.9 * _SAFE},
        "horizon": 100_000,
        "ratio_by_horizon": byh,
        "dt_crit_by_horizon": {h: {p: v * _SAFE for p, v in q.items()} for h, q in byh.items()},
        "p_fail_by_horizon": {h: [[q["5"] * _SAFE, 0.5]] for h, q in byh.items()},
        "ratio_5": q5[0],
        "ratio_50": q5[1],
        "ratio_95": q5[2],
        "tangent_ratio": 0.6,
        "linear_prediction": 0.5,
        "horizon_dependent": q5[1] < q4[0],
        "holds": min(q4[0], q5[0]) >= 1.0,
        "factor": min(1.0, q5[0]),
        "cage_fraction": 0.0,
        "contact_list_held": True,
        "from_record": False,
    }


def _rows() -> list[dict]:
    # the two-body chain holds at 1e4 and 1e5 (5 % points 1.2 and 1.1 Delta t_safe, median
    # at 1e5 above the 5 % point at 1e4: not horizon-dependent); the five-body one too
    return [_row(CHEAP, (1.2, 1.3, 1.4), (1.1, 1.25, 1.3)),
            _row("chain N=5, walls both", (1.5, 1.6, 1.7), (1.4, 1.5, 1.6))]  # fmt: skip


def test_merge_judges_over_the_three_horizons(tmp_path):
    """At 1e6 steps the synthetic lanes fail from 0.90 to 1.05 Delta t_safe: the 5 % point
    falls below Delta t_safe (holds turns false, the verdict refuted, the worst case the
    two-body chain at 1e6) and the median below the 1e4 5 % point (horizon-dependent);
    the five-body chain, left out of the record, keeps its two horizons and is named."""
    rows = _rows()
    before = claim_mod.measurement_from_rows(rows, claim_mod.FULL_HORIZONS, None)
    data = _synthetic(0.90, 1.05)
    record, why = rec_mod.read_record(
        _write(tmp_path, data), claim_mod.record_settings(), _EXPECTED
    )
    merged, long = claim_mod.merge_record(rows, record, why)
    m = claim_mod.measurement_from_rows(merged, claim_mod.FULL_HORIZONS, long)
    two, five = merged
    lanes = sorted(data["cases"][0]["dt_crit"])
    # independent of the claim's code: the lower quantile's rank and the P_fail steps
    q5, q50 = lanes[math.floor(0.05 * (N - 1))], lanes[math.floor(0.5 * (N - 1))]
    curve = [(x, (k + 1) / N) for k, x in enumerate(lanes)]
    corrected, _ = claim_mod.corrected(m.to_dict()["measured"], {})
    checks = {
        "verified before": before.verdict == "verified",
        "refuted after": m.verdict == "refuted" and m.counterexample["case"] == CHEAP,
        "three horizons": list(two["ratio_by_horizon"]) == ["10000", "100000", "1000000"]
        and m.figures["horizons"] == [10_000, 100_000, 1_000_000],
        "5 % point": two["ratio_5"] == q5 / _SAFE and two["ratio_50"] == q50 / _SAFE,
        "P_fail line": two["p_fail_by_horizon"]["1000000"] == curve,
        "holds false": two["holds"] is False and two["factor"] == q5 / _SAFE,
        "horizon-dependent": two["horizon_dependent"] is True and q50 < 1.2 * _SAFE,
        "from record": two["from_record"] is True and two["horizon"] == 1_000_000,
        "tangent": two["tangent_ratio"] == 0.5,
        "left-out row unchanged": five == rows[1],
        "inputs unchanged": rows == _rows(),
        "evidence": "1e6-step horizon of chain N=2, walls both from the record" in m.evidence
        and "chain N=5, walls both not in that record (not run (time))" in m.evidence
        and "commit 0123456789ab, 2026-01-01T00:00:00Z" in m.evidence,
        "corrected": "1e6 steps" in corrected and CHEAP in corrected,
    }
    failed = [k for k, ok in checks.items() if not ok]
    assert_true(
        not failed,
        got=f"failed {failed}; row {json.dumps({k: two[k] for k in ('ratio_5', 'holds', 'horizon_dependent')})}"
        f", evidence {m.evidence!r}",
        should="the merge judged over 1e4, 1e5 and 1e6 steps",
        claim=CLAIM,
        call="merge_record(rows at 1e4/1e5, synthetic 1e6 record)",
    )  # fmt: skip


def test_merge_keeps_a_holding_case_holding(tmp_path):
    """Lanes at 1.15 to 1.30 Delta t_safe at 1e6: the bound still holds (5 % point above
    1); the median (about 1.22) is above the 1e4 5 % point (1.2): not horizon-dependent."""
    record, why = rec_mod.read_record(
        _write(tmp_path, _synthetic(1.15, 1.30)), claim_mod.record_settings(), _EXPECTED
    )
    merged, _ = claim_mod.merge_record(_rows(), record, why)
    two = merged[0]
    assert_true(
        why is None and two["holds"] is True and two["horizon_dependent"] is False,
        got=f"note {why!r}, holds {two['holds']}, horizon_dependent {two['horizon_dependent']}",
        should="holds, not horizon-dependent",
        claim=CLAIM,
        call="merge_record(rows, a record of lanes from 1.15 to 1.30 dt_safe)",
    )


def test_quick_measurement_does_not_read_the_record(monkeypatch):
    """The test suite's measurement (quick) never opens the record."""

    def refuse(*a, **k):
        raise AssertionError("quick read the record")

    monkeypatch.setattr(claim_mod, "read_record", refuse)
    # One quick case is enough to see which path the measurement takes (all of them take
    # ~65 s, and test_sec6_assemblies measures them already).
    real_cases = claim_mod.cases
    monkeypatch.setattr(claim_mod, "cases", lambda quick=False: real_cases(quick)[:1])
    m = claim_mod.measure.__wrapped__(True)
    assert_true(
        "long_horizon" not in m.figures and "record" not in m.evidence,
        got=f"figures {sorted(m.figures)}, evidence {m.evidence[-80:]!r}",
        should="no long_horizon, no record in the evidence",
        claim=CLAIM,
        call="sec6_assemblies.measure(quick=True)",
    )


def _section(measured: dict) -> str:
    """The report's assemblies section (Markdown) for the claim's ``measured``."""
    r = {
        "claims": [{"id": claim_mod.ID, "measured": jsonable(measured)}],
        "assemblies": {
            "claim": claim_mod.ID,
            "linear": {"rtol": 1e-6, "criterion": "-", "k": 1.0, "m": 1.0, "rows": []},
            "figures": {"p_fail": "figures/p.png", "factor": "figures/f.png"},
        },
    }
    out: list[str] = []
    markdown_lines(assemblies_blocks(r), out)
    return "\n".join(out)


def test_report_says_which_horizon_came_from_the_record(tmp_path):
    """Merged: the section names the record, its commit and date, and marks the horizon
    in the row it came from; ignored: the section gives the note."""
    record, why = rec_mod.read_record(
        _write(tmp_path, _synthetic()), claim_mod.record_settings(), _EXPECTED
    )
    merged = claim_mod.measurement_from_rows(*_merged(record, why))
    ignored = claim_mod.measurement_from_rows(*_merged(None, "schema is 'x'"))
    md, md_ignored = _section(merged.figures), _section(ignored.figures)
    row = next(line for line in md.splitlines() if line.startswith(f"| {CHEAP} |"))
    other = next(line for line in md.splitlines() if line.startswith("| chain N=5"))
    checks = {
        "record named": "`reports/assemblies_1e6.json`" in md,
        "commit and date": "commit 0123456789ab, 2026-01-01T00:00:00Z" in md,
        "horizon marked": "; 1,000,000: 0.905 (record) |" in row and "(record)" not in other,
        "left out named": "chain N=5, walls both: not run (time)" in md,
        "note when ignored": "(1e6 record ignored: schema is 'x')" in md_ignored
        and "(record)" not in md_ignored,
    }
    failed = [k for k, ok in checks.items() if not ok]
    assert_true(
        not failed,
        got=f"failed {failed}; row {row!r}",
        should="the record's horizon, commit and date named, its horizon marked",
        claim=CLAIM,
        call="assemblies_blocks(results with a merged / an ignored record)",
    )


def _merged(record, why):
    rows, long = claim_mod.merge_record(_rows(), record, why)
    return rows, claim_mod.FULL_HORIZONS, long


def test_a_report_run_leaves_the_record_in_place(tmp_path):
    """`hcv report` into reports/ replaces only the files of its manifest (`swap_in`); the
    record, written by the campaign, is not one of them and stays byte for byte."""
    out = tmp_path / "reports"
    with swap_in(out) as new:  # a first report
        (new / "index.md").write_text("old")
    record = out / RECORD.name
    record.write_text(json.dumps(_synthetic()))
    before = record.read_bytes()
    with swap_in(out) as new:  # the next report, which writes other files
        (new / "index.md").write_text("new")
        (new / "results.json").write_text("{}")
    assert_true(
        record.is_file() and record.read_bytes() == before and (out / "index.md").read_text() == "new",
        got=f"record {'kept' if record.is_file() else 'deleted'}",
        should="kept byte for byte while the report's own files are replaced",
        claim=CLAIM,
        call="report._files.swap_in twice into a folder holding the record",
    )  # fmt: skip


@pytest.mark.parametrize("tampered", [False, True])
def test_full_measurement_reads_the_record(tmp_path, monkeypatch, tampered):
    """`measure(quick=False)` wired end to end on one cheap case at short horizons (the
    claim's cases and horizons patched, its record a synthetic one of that case with the
    claim's own Delta t_safe): merged when valid, the note and two horizons when not."""
    label, d, z, asm = next(c for c in claim_mod.cases() if c[0] == CHEAP)
    _, safe, _ = reference_step(claim_mod.case_model(asm))
    data = _synthetic()
    case = data["cases"][0]
    scale = safe["paper"] / _SAFE  # the synthetic lanes in units of the real Delta t_safe
    for key in ("dt_crit", "dt_stable"):
        case[key] = [x * scale for x in case[key]]
    case["quantiles"] = {p: v * scale for p, v in case["quantiles"].items()}
    case["dt_safe"] = safe
    data["left_out"] = []
    if tampered:
        data["settings"]["grid"]["step"] = 0.01
    monkeypatch.setattr(claim_mod, "cases", lambda quick=False: [(label, d, z, asm)])
    monkeypatch.setattr(claim_mod, "FULL_HORIZONS", (1_000, 2_000))
    monkeypatch.setattr(claim_mod, "RECORD_PATH", _write(tmp_path, data))
    m = claim_mod.measure.__wrapped__(False)
    row = m.figures["rows"][0]
    if tampered:
        ok = (
            not row["from_record"]
            and m.figures["horizons"] == [1_000, 2_000]
            and "; 1e6 record ignored: settings.grid is {'lo': 0.05" in m.evidence
        )  # fmt: skip
    else:
        ok = (
            row["from_record"]
            and list(row["ratio_by_horizon"]) == ["1000", "2000", "1000000"]
            and m.figures["horizons"] == [1_000, 2_000, 1_000_000]
            and row["ratio_5"] == sorted(case["dt_crit"])[1] / safe["paper"]
            and m.figures["long_horizon"]["merged"] == [CHEAP]
        )
    assert_true(
        ok,
        got=f"from_record {row['from_record']}, horizons {m.figures['horizons']}, evidence "
        f"{m.evidence[-160:]!r}",
        should="the note and two horizons" if tampered else "merged: three horizons",
        claim=CLAIM,
        call="sec6_assemblies.measure(quick=False) on one case, record "
        + ("tampered" if tampered else "valid"),
    )


def _later_run() -> dict:
    """A later run's record (`run_record`'s form) of the five-body chain alone."""
    new = _synthetic(1.15, 1.30)
    new["cases"][0] = {**new["cases"][0], "case": "chain N=5, walls both",
                       **_SHAPES["chain N=5, walls both"]}  # fmt: skip
    extra = {"machine": {}, "load_average_start": [1.0, 1.0, 1.0], "workers": 2,
             "load_average_end": [1.0, 1.0, 1.0], "wall_s": 1.0, "cpu_s": 1.0}  # fmt: skip
    return {**new, **extra, "commit": "fedcba9876543210", "date": "2026-01-02T00:00:00Z",
            "left_out": [{"case": CHEAP, "why": "not run"}]}  # fmt: skip


def test_a_later_run_is_added_with_its_own_provenance(tmp_path):
    """`--add-to`: the five-body chain measured later joins the record with its own commit
    and date; the claim reads both, and the evidence and the report name each run."""
    both = assembly_long.add_to(_synthetic(), _later_run())
    record, why = rec_mod.read_record(
        _write(tmp_path, both), claim_mod.record_settings(), _EXPECTED
    )
    rows, long = claim_mod.merge_record(_rows(), record, why)
    m = claim_mod.measurement_from_rows(rows, claim_mod.FULL_HORIZONS, long)
    want = (
        "(chain N=2, walls both: commit 0123456789ab, 2026-01-01T00:00:00Z; chain N=5, walls "
        "both: commit fedcba987654, 2026-01-02T00:00:00Z)"
    )
    assert_true(
        why is None
        and both["left_out"] == []
        and [a["cases"] for a in both["added"]] == [["chain N=5, walls both"]]
        and all(r["from_record"] for r in rows)
        and want in m.evidence
        and "chain N=5, walls both at commit fedcba987654, 2026-01-02" in _section(m.figures),
        got=f"note {why!r}, left out {both['left_out']}, evidence {m.evidence[-220:]!r}",
        should=f"both cases merged, nothing left out, the evidence holding {want!r}",
        claim=CLAIM,
        call="assembly_long.add_to(first run, later run) then read_record",
    )


def test_a_later_run_cannot_replace_a_recorded_case():
    again = _later_run()
    again["cases"][0]["case"] = CHEAP
    with pytest.raises(HCVInputError, match="already in the record"):
        assembly_long.add_to(_synthetic(), again)
    other = _later_run()
    other["settings"] = {**other["settings"], "n_lanes": 16}
    with pytest.raises(HCVInputError, match="other settings"):
        assembly_long.add_to(_synthetic(), other)
