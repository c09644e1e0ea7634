"""Tool tests of the critical-step search: failure kinds, criterion parsing, bounds, memory.

No claim marks: these test the measuring instrument (`reference_impl.stability.search`,
`reference_impl.studies.dtcrit_map`), not a statement of the paper. The done-when checks
of issue 8 section 2 (linear spring holds, Hertz is a runaway) and the bad-input
items of issue 12 that concern `hcv dt-crit` live here.
"""

from __future__ import annotations

import json
import math
import re
import subprocess
import sys
import tracemalloc
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from reference_impl.claims.sec6_dt_safe_bound import kind_counts, verdict_from_map
from reference_impl.errors import HCVInputError
from reference_impl.potentials import Expression, PowerLaw
from reference_impl.stability.recommend import recommended_step
from reference_impl.stability.search import (
    FAILURE_KINDS,
    MAX_LANES_PER_CALL,
    MAX_N_PHASES,
    MAX_N_STEPS,
    MAX_SPEEDS,
    EnergyGrowth,
    ImpactGain,
    SearchGrid,
    _chunks,
    _Search,
    parse_criterion,
    search_scene,
)
from reference_impl.studies.dtcrit_map import MapCase, dt_crit_map
from verification.assertions import assert_true

HERTZ = PowerLaw(1.0, 1.5)
LINEAR = PowerLaw(1.0, 1.0)
ROOT = Path(__file__).resolve().parents[1]
# The search's bracket resolution (0.1 % of dt_safe): two runs of one threshold agree to it.
RES = SearchGrid().resolution


def _cli(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    env = {"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"}
    return subprocess.run(
        [sys.executable, "-m", "reference_impl.cli", *args],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )


# ----------------------------------------------------------------------------
# issue 8 section 2: done-when checks
# ----------------------------------------------------------------------------
def test_linear_two_sided_spring_holds_with_dt_crit_at_2_over_omega(tmp_path):
    """`hcv dt-crit` on m = k = v0 = 1, two-sided linear spring: holds, ratio in [0.995, 1]."""
    (tmp_path / "lin.toml").write_text(
        'name = "linear"\nmass = 1.0\nvelocities = [1.0]\nkind = "two-sided"\n\n'
        '[potential]\nfamily = "power"\nk = 1.0\np = 1.0\n'
    )
    out = _cli("dt-crit", "lin.toml", "--json", cwd=tmp_path)
    assert_true(
        out.returncode == 0,
        got=f"exit {out.returncode}: {out.stderr.strip()[-300:]}",
        should="exit 0",
        claim="tool",
        call="hcv dt-crit lin.toml --json",
    )
    r = json.loads(out.stdout)["results"][0]
    ratio = r["dt_crit"] / 2.0  # 2 / omega = 2 s for k = m = 1
    assert_true(
        r["holds"] is True and 0.995 <= ratio <= 1.0 and r["failure_kind"] == "runaway",
        got=f"holds {r['holds']}, dt_crit/(2/omega) = {ratio}, kind {r['failure_kind']}",
        should="holds true, ratio in [0.995, 1.0], kind runaway (at 2/omega)",
        claim="tool",
        call="hcv dt-crit linear spring",
    )
    # The bounded orbit below 2/omega crosses 100 E0 (peak E0 / (1 - (omega dt/2)^2)) but is
    # reported as bounded, not as the failure: its step and peak are in the result.
    x = r["dt_bounded"] / 2.0
    assert_true(
        0.99 < x < 1.0 and r["bounded_E_max_over_E0"] <= 1 / (1 - x * x) * (1 + 1e-9),
        got=f"dt_bounded/(2/omega) = {x}, peak {r['bounded_E_max_over_E0']}",
        should="in (0.99, 1) with peak <= E0/(1-x^2)",
        claim="tool",
        call="dt_bounded",
    )


@pytest.mark.parametrize("text", ["", "   "])
def test_cli_refuses_an_empty_criterion(tmp_path, text):
    """`--criterion ""` is parsed (not taken as the default): exit 2, one line, no search."""
    out = _cli("dt-crit", "hertz", "--criterion", text, cwd=tmp_path)
    lines = out.stderr.strip().splitlines()
    assert_true(
        out.returncode == 2 and len(lines) == 1 and "criterion" in lines[0] and not out.stdout,
        got=f"exit {out.returncode}, stderr {out.stderr!r}, stdout {out.stdout[:200]!r}",
        should="exit 2 with one line naming the criterion, nothing printed on stdout",
        claim="tool",
        call=f"hcv dt-crit hertz --criterion {text!r}",
    )


def test_cli_table_shows_failure_kind_and_sizes(tmp_path):
    """The text table carries failure_kind, dt_bounded and dt_accuracy as the JSON does."""
    (tmp_path / "lin.toml").write_text(
        'name = "linear"\nmass = 1.0\nvelocities = [1.0]\nkind = "two-sided"\n\n'
        '[potential]\nfamily = "power"\nk = 1.0\np = 1.0\n'
    )
    out = _cli("dt-crit", "lin.toml", "--criterion", "n_steps=2e4", cwd=tmp_path)
    r = search_scene(LINEAR, 1.0, [1.0], "two-sided", criterion=EnergyGrowth(n_steps=20_000))[0]
    # Off a terminal the table is plain text: label, then the value, 2+ spaces apart.
    rows = {
        cells[0].removesuffix(" [s]"): cells[1]
        for cells in (re.split(r"\s{2,}", line.strip()) for line in out.stdout.splitlines())
        if len(cells) >= 2
    }
    # failure kind (runaway / bounded / accuracy), the bounded step and (impacts
    # only, so absent here: "—") the accuracy step, as `_fmt` prints them.
    want = {
        "failure kind": r.failure_kind,
        "dt_bounded": f"{r.dt_bounded:.10g}",
        "dt_accuracy": "—",
    }
    assert_true(
        out.returncode == 0 and all(rows.get(k) == v for k, v in want.items()),
        got=f"exit {out.returncode}: {rows}",
        should=f"rows {want}",
        claim="tool",
        call="hcv dt-crit lin.toml (table)",
    )


def test_hertz_two_sided_is_a_runaway_below_dt_safe():
    """Two-sided Hertz p = 1.5: holds False, ratio ~0.75 (issue 8 measured 0.7524), runaway."""
    r = search_scene(HERTZ, 1.0, [1.0], "two-sided")[0]
    # 0.75 +- 0.01: the threshold issue 8 measured (0.7524), to 10 bracket widths.
    assert_true(
        not r.holds
        and abs(r.ratio - 0.75) < 0.01
        and r.failure_kind == "runaway"
        and r.runaway_evidence == "confirmed",
        got=f"holds {r.holds}, ratio {r.ratio}, kind {r.failure_kind} ({r.runaway_evidence})",
        should="holds False, ratio ~0.75, runaway (confirmed)",
        claim="tool",
        call="search_scene hertz two-sided",
    )
    ce = r.counterexample
    assert_true(
        ce is not None and ce["E_max_over_E0"] > EnergyGrowth().confirm_level,
        got=str(ce),
        should="a counterexample above the confirmation level",
        claim="tool",
        call="counterexample",
    )


def test_hertz_runaway_does_not_move_with_the_confirmation():
    """A runaway is the same step whatever the confirmation level and horizon."""
    a = search_scene(
        HERTZ,
        1.0,
        [1.0],
        "two-walls",
        criterion=EnergyGrowth(confirm_factor=10.0, confirm_horizon=1),
    )[0]
    b = search_scene(
        HERTZ,
        1.0,
        [1.0],
        "two-walls",
        criterion=EnergyGrowth(confirm_factor=1e6, confirm_horizon=20),
    )[0]
    assert_true(
        abs(a.ratio - b.ratio) <= 2 * RES and a.failure_kind == b.failure_kind == "runaway",
        got=f"{a.ratio} vs {b.ratio}",
        should="equal to 2 brackets",
        claim="tool",
        call="search_scene two-walls",
    )


def test_single_impact_failure_is_accuracy_not_instability():
    """Hertz impact: the rebound-gain threshold is reported as accuracy; holds stays True."""
    r = search_scene(HERTZ, 1.0, [1.0], "impact")[0]
    assert_true(
        r.holds
        and r.failure_kind == "accuracy"
        and r.dt_accuracy < r.dt_crit
        and abs(r.accuracy_ratio - r.dt_accuracy / r.dt_safe) < 1e-15
        and r.dt_crit - r.dt_accuracy <= RES * r.dt_safe * (1 + 1e-9),
        got=f"holds {r.holds}, kind {r.failure_kind}, dt_acc {r.dt_accuracy}, dt_crit {r.dt_crit}",
        should="holds, accuracy, dt_accuracy just below",
        claim="tool",
        call="search_scene hertz impact",
    )
    # The threshold moves with the tolerance, as an accuracy threshold does.
    loose = search_scene(HERTZ, 1.0, [1.0], "impact", criterion=ImpactGain(tol=1.0))[0]
    assert_true(
        loose.dt_accuracy > 2 * r.dt_accuracy,
        got=f"{loose.dt_accuracy}",
        should=f"> 2 x {r.dt_accuracy}",
        claim="tool",
        call="tol=1.0",
    )


@pytest.mark.parametrize("kind", ["impact", "two-sided", "two-walls"])
def test_result_dict_has_failure_kind(kind):
    r = search_scene(PowerLaw(1.0, 2.0), 1.0, [1.0], kind)[0]
    d = json.loads(json.dumps(r.to_dict()))
    keys = {
        "failure_kind",
        "dt_bounded",
        "bounded_E_max_over_E0",
        "dt_accuracy",
        "accuracy_ratio",
        "runaway_evidence",
        "holds",
        "criterion",
    }
    assert_true(
        keys <= set(d) and d["failure_kind"] in FAILURE_KINDS,
        got=str(sorted(d)),
        should=f"{sorted(keys)} with kind in {FAILURE_KINDS}",
        claim="tool",
        call=f"to_dict {kind}",
    )


def test_map_rows_and_verdict_count_only_runaways():
    """Map rows carry failure_kind; the verdict counts runaways below dt_safe and nothing else."""
    case = MapCase("power", "p=1.5", HERTZ, 1.0, (1.0,), 1.5)
    df = dt_crit_map([case])
    assert_true(
        list(df.failure_kind) == ["accuracy", "runaway", "runaway"],
        got=str(list(df.failure_kind)),
        should="accuracy, runaway, runaway",
        claim="tool",
        call="dt_crit_map",
    )
    # Synthetic rows, one of each kind below the bound: only the runaway refutes.
    base = dict(
        family="power",
        case="x",
        p=1.0,
        v0=1.0,
        degenerate=False,
        ratio=0.5,
        bounded_ratio=math.inf,
        accuracy_ratio=np.nan,
        runaway_evidence=None,
        recommended_ratio=2.0,
        geometry="stiffening",
        criterion="synthetic",
        n_steps=100_000,
        counterexample_steps=1_000,
    )
    rows = pd.DataFrame(
        [
            base
            | dict(
                scene="two-sided", failure_kind="runaway", holds=False, runaway_evidence="confirmed"
            ),
            base
            | dict(
                scene="two-walls",
                failure_kind="bounded",
                holds=True,
                ratio=math.inf,
                bounded_ratio=0.8,
            ),
            base | dict(scene="impact", failure_kind="accuracy", holds=True, accuracy_ratio=0.49),
            base | dict(scene="two-sided", failure_kind=None, holds=True, ratio=math.inf),
        ]
    )
    c = kind_counts(rows)
    assert_true(
        (c["runaway"], c["bounded"], c["accuracy"]) == (1, 1, 1),
        got=str(c),
        should="one of each",
        claim="tool",
        call="kind_counts",
    )
    v = verdict_from_map(rows.iloc[1:])
    assert_true(
        v.verdict == "verified" and v.figures["per_kind"] == dict(runaway=0, bounded=1, accuracy=1),
        got=f"{v.verdict}: {v.figures['per_kind']}",
        should="verified: bounded and accuracy are not instabilities",
        claim="tool",
        call="verdict_from_map",
    )
    assert_true(
        verdict_from_map(rows).verdict == "refuted",
        got=verdict_from_map(rows).verdict,
        should="refuted by the runaway",
        claim="tool",
        call="verdict_from_map",
    )


# ----------------------------------------------------------------------------
# issue 12: criterion parsing, bounds, memory
# ----------------------------------------------------------------------------
@pytest.mark.parametrize(
    "text, kind, word",
    [
        ("n_steps=1.5", "two-sided", "1.5"),
        ("n_phases=2.5", "impact", "2.5"),
        ("factor=10,factor=20", "two-sided", "factor"),
        ("tol=0.1, tol=0.1", "impact", "tol"),
        ("factor=nan", "two-walls", "nan"),
        ("factor=inf", "two-sided", "inf"),
        ("tol=-inf", "impact", "-inf"),
        ("n_steps=1e400", "two-sided", "1e400"),
        ("n_steps=1e8", "two-sided", "100000000"),
        ("n_phases=1e6", "impact", "1000000"),
        ("factor=1e13", "two-sided", "10000000000000"),
        ("n_steps=1e7,confirm_horizon=100", "two-sided", "100"),
        ("", "impact", "empty"),
        ("factor=10,", "two-sided", "''"),
        ("n_steps=abc", "two-sided", "abc"),
    ],
)
def test_parse_criterion_refuses_with_one_line(text, kind, word):
    with pytest.raises(HCVInputError) as err:
        parse_criterion(text, kind)
    msg = str(err.value)
    assert_true(
        "\n" not in msg and word in msg,
        got=repr(msg),
        should=f"one line naming {word!r}",
        claim="tool",
        call=f"parse_criterion({text!r})",
    )


def test_parse_criterion_accepts_integral_decimal_notation():
    got = parse_criterion("factor=1e3, n_steps=2e5, confirm_factor=100", "two-sided")
    assert_true(
        got == EnergyGrowth(1000.0, 200_000, 100.0) and type(got.n_steps) is int,
        got=repr(got),
        should="EnergyGrowth(1000, 200000, 100)",
        claim="tool",
        call="parse_criterion",
    )


def test_sizes_are_bounded_before_any_work():
    for make in (
        lambda: search_scene(HERTZ, 1.0, [1.0] * (MAX_SPEEDS + 1), "impact"),
        lambda: search_scene(HERTZ, 1.0, iter(lambda: 1.0, None), "impact"),
        lambda: SearchGrid(step=1e-7),
        lambda: SearchGrid(refine_points=10**6),
        lambda: SearchGrid(resolution=0.0),
        lambda: EnergyGrowth(n_steps=MAX_N_STEPS + 1),
        lambda: ImpactGain(n_phases=MAX_N_PHASES + 1),
    ):
        with pytest.raises(HCVInputError) as err:
            make()
        assert_true(
            "\n" not in str(err.value),
            got=repr(str(err.value)),
            should="one line",
            claim="tool",
            call="bounds",
        )


def test_impact_lanes_are_chunked_whatever_n_phases():
    """One round of an impact search never puts more than MAX_LANES_PER_CALL lanes in a call."""
    s = _Search(1.0, 1.0, ImpactGain(n_phases=MAX_N_PHASES).phases())
    need = {0: SearchGrid().scan()}
    sizes = [
        sum(d.size * p.size for d, p in part.values())
        for part in _chunks([s], need, MAX_LANES_PER_CALL)
    ]
    total = need[0].size * s.phases.size
    assert_true(
        max(sizes) <= MAX_LANES_PER_CALL and sum(sizes) == total,
        got=f"max {max(sizes)}, total {sum(sizes)}",
        should=f"<= {MAX_LANES_PER_CALL}, total {total}",
        claim="tool",
        call="_chunks",
    )


def test_impact_search_memory_does_not_grow_with_n_phases():
    """Peak traced memory with 2000 phases stays within 3x that with 200 (was ~10x: per phase)."""

    def peak(n):
        tracemalloc.start()
        search_scene(HERTZ, 1.0, [1.0], "impact", criterion=ImpactGain(n_phases=n), recommend=None)
        _, top = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        return top

    small, large = peak(200), peak(2000)
    # 3x: one chunk of MAX_LANES_PER_CALL lanes against ~60k lanes of the small run, plus
    # the per-dt bookkeeping; memory growing per phase would give ~10x.
    assert_true(
        large < 3 * small,
        got=f"{large / 1e6:.1f} MB vs {small / 1e6:.1f} MB",
        should="< 3x",
        claim="tool",
        call="search_scene n_phases",
    )


# ----------------------------------------------------------------------------
# issue 12: recommended_step on concave (softening) contacts
# ----------------------------------------------------------------------------
_CONCAVE = ("tanh({a}*q)", "log(1 + {a}*q)", "sqrt({a}*q)", "atan({a}*q)", "asinh({a}*q)")


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    form=st.sampled_from(_CONCAVE),
    a=st.floats(0.1, 10.0),
    m=st.floats(0.01, 10.0),
    frac=st.floats(0.05, 0.9),
    kind=st.sampled_from(["impact", "two-sided", "two-walls"]),
)
def test_recommended_step_is_finite_on_concave_contacts(form, a, m, frac, kind):
    """U'' < 0: no math domain error; NaN (no recommendation: outside the measured classes,
    where the chord stiffness was measured unsafe), never an exception."""
    pot = Expression(form.format(a=repr(a)))
    v0 = math.sqrt(2 * frac / m)  # E = frac J: every form here is unbounded
    dt = recommended_step(pot, m, v0, kind)
    assert_true(
        math.isnan(dt),
        got=repr(dt),
        should="nan",
        claim="tool",
        call=f"recommended_step({pot!r}, m={m}, v0={v0}, {kind})",
    )


@pytest.mark.parametrize("kind", ["impact", "two-sided", "two-walls"])
def test_recommended_step_on_sin_contact(kind):
    """The issue's reproduction U = sin(q), m = 1, v0 = 0.5 (E = 0.125 J, q_max = 0.125 m)."""
    dt = recommended_step(Expression("sin(q)"), 1.0, 0.5, kind)
    assert_true(
        math.isnan(dt),
        got=repr(dt),
        should="nan",
        claim="tool",
        call=f"recommended_step(sin(q), {kind})",
    )
    # A convex neighbour (U'' > 0 on the path) still gets its finite step.
    dt = recommended_step(Expression("q**1.5"), 1.0, 0.5, kind)
    assert_true(
        math.isfinite(dt) and dt > 0,
        got=repr(dt),
        should="finite > 0",
        claim="tool",
        call=f"recommended_step(q**1.5, {kind})",
    )
