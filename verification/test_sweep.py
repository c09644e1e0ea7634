"""``hcv sweep``: spec validation and cases run in this process (no cluster).

A spec expands to the cartesian product of its lists, with keys that depend on the
parameters only; bad specs are refused in one line; many cases are validated quickly.
The tests on a real ``distributed.LocalCluster`` are in ``test_sweep_cluster.py``, the
sweeps of ``bench:ADAPTER`` tasks in ``test_sweep_bench.py``.
"""

from __future__ import annotations

import json
import textwrap

import pytest
from hypothesis import given
from hypothesis import strategies as st

from reference_impl.sweep import (
    MAX_CASES,
    CaseTimeout,
    SweepSpecError,
    parse_spec,
    run_case,
    spec_from_dict,
)
from verification._sweeps import SPEC, cli
from verification.assertions import assert_true


# --------------------------------------------------------------------------
# spec validation (no cluster)
# --------------------------------------------------------------------------
def test_example_spec_expands_to_the_cartesian_product():
    spec = parse_spec(SPEC, "t")
    params = [tuple(c.params.values()) for c in spec.cases]
    want = [(p, m) for p in (1.0, 1.5, -1.0, 3.0) for m in (1.0, 2.0)]
    assert_true(
        params == want,
        got=str(params),
        should=str(want),
        claim="sweep",
        call="parse_spec: last key varies fastest",
    )
    keys = {c.key for c in spec.cases}
    assert_true(
        len(keys) == 8,
        got=f"{len(keys)} distinct keys",
        should="8",
        claim="sweep",
        call="parse_spec keys",
    )
    again = [c.key for c in parse_spec(SPEC, "other-name").cases]
    assert_true(
        again == [c.key for c in spec.cases],
        got="keys changed with the source name",
        should="keys depend on the parameters only",
        claim="sweep",
        call="parse_spec",
    )
    other = parse_spec(SPEC.replace("tol=0.5", "tol=0.4"), "t")
    assert_true(
        not keys & {c.key for c in other.cases},
        got="same keys for another criterion",
        should="different keys",
        claim="sweep",
        call="parse_spec keys",
    )
    bad = [c for c in spec.cases if c.error]
    assert_true(
        [c.params["potential.p"] for c in bad] == [-1.0, -1.0],
        got=str([c.params for c in bad]),
        should="the two p = -1 cases invalid",
        claim="sweep",
        call="parse_spec",
    )
    assert_true(
        "potential.p" in bad[0].error and "-1" in bad[0].error,
        got=bad[0].error,
        should="an error naming potential.p = -1",
        claim="sweep",
        call="parse_spec",
    )


@pytest.mark.parametrize(
    ("edit", "needle"),
    [
        (lambda s: s.replace('task = "dt-crit"', 'task = "dtcrit"'), "task"),
        (lambda s: s.replace('task = "dt-crit"', 'task = "dt-crit"\nworkers = 3'), "workers"),
        (lambda s: s.replace('"mass" = [1.0, 2.0]', '"mass" = 2.0'), "mass"),
        (lambda s: s.replace('"mass" = [1.0, 2.0]', '"mass" = [1.0, 1.0]'), "repeats"),
        (lambda s: s.replace('"mass" = [1.0, 2.0]', '"mass" = []'), "mass"),
        (lambda s: s.replace("tol=0.5,n_phases=2", "factor=10"), "factor"),
        (lambda s: s.replace('task = "dt-crit"', 'task = "solve"'), "criterion"),
        (
            lambda s: s.replace('"potential.p" = [1.0, 1.5, -1.0, 3.0]', '"potential.q" = [1, 2]'),
            "potential.q",
        ),
        (
            lambda s: s + '"velocities" = [' + ", ".join(str(1 + i) for i in range(20_000)) + "]\n",
            str(MAX_CASES),
        ),
        (lambda s: s.replace("[sweep]", '[sweep]\n".." = [1]'), ".."),
        (lambda s: s.replace("criterion", "timeout = -1\ncriterion"), "timeout"),
    ],
)
def test_bad_specs_are_refused_with_one_line(edit, needle):
    with pytest.raises(SweepSpecError) as info:
        parse_spec(edit(SPEC), "bad.toml")
    msg = str(info.value)
    assert_true(
        needle in msg and "\n" not in msg,
        got=msg,
        should=f"one line naming {needle!r}",
        claim="sweep",
        call="parse_spec",
    )


def test_cli_bad_spec_exit_2_nothing_written(tmp_path, capsys):
    spec = tmp_path / "s.toml"
    spec.write_text(SPEC.replace('"mass" = [1.0, 2.0]', '"mass" = "heavy"'), encoding="utf-8")
    out = tmp_path / "out"
    code, stdout, err = cli(["sweep", str(spec), "--out", str(out)], capsys)
    lines = err.strip().splitlines()
    assert_true(
        code == 2 and len(lines) == 1 and "mass" in lines[0] and not out.exists(),
        got=f"exit {code}, stderr {err!r}, out exists {out.exists()}",
        should="exit 2, one line naming mass, no output",
        claim="sweep",
        call="hcv sweep",
    )
    spec.write_text(SPEC, encoding="utf-8")
    code, _, err = cli(["sweep", str(spec), "--out", str(out), "--workers", "0"], capsys)
    assert_true(
        code == 2 and "--workers" in err and not out.exists(),
        got=f"{code} {err!r}",
        should="exit 2 naming --workers",
        claim="sweep",
        call="hcv sweep --workers 0",
    )


@given(
    st.lists(st.integers(1, 4), min_size=1, max_size=3),
    st.sampled_from(["impact", "two-sided"]),
)
def test_any_sweep_expands_to_its_product_with_unique_keys(sizes, kind):
    """For any list lengths: len = product, params as given, keys unique, TOML text round-trips."""
    import tomllib

    paths = ["potential.p", "mass", "velocities"][: len(sizes)]
    sweep = {p: [1.0 + 0.5 * i for i in range(n)] for p, n in zip(paths, sizes, strict=True)}
    data = {
        "task": "dt-crit",
        "scene": {
            "mass": 1.0,
            "velocities": [1.0],
            "kind": kind,
            "potential": {"family": "power", "k": 1.0, "p": 1.5},
        },
        "sweep": sweep,
    }
    spec = spec_from_dict(data, "prop")
    n = 1
    for s in sizes:
        n *= s
    keys = {c.key for c in spec.cases}
    scene_ok = all(
        c.scene["potential"]["p"] == c.params.get("potential.p", 1.5)
        and c.scene["velocities"] == [c.params.get("velocities", 1.0)]
        for c in spec.cases
    )
    ok = len(spec.cases) == n and len(keys) == n and scene_ok and not spec.invalid
    assert_true(
        ok and tomllib.loads(spec.text) == data,
        got=f"{len(spec.cases)} cases, {len(keys)} keys, scenes ok {scene_ok}",
        should=f"{n} valid cases, unique keys",
        claim="sweep",
        call=f"spec_from_dict(sweep={sweep})",
    )


# --------------------------------------------------------------------------
# issue 22: many cases validated quickly
# --------------------------------------------------------------------------
def test_each_distinct_potential_is_validated_once(monkeypatch):
    """Issue 22: 1e5 cases of one expression took ~40 min to validate (25 ms each)."""
    from reference_impl.scenes import _scene

    built = []
    real = _scene._potential

    def counting(err, table, path, depth=0):
        if depth == 0:
            built.append(json.dumps(table, sort_keys=True))
        return real(err, table, path, depth)

    monkeypatch.setattr(_scene, "_potential", counting)
    masses = [round(0.5 + 0.01 * i, 4) for i in range(300)]
    spec_text = textwrap.dedent(
        f"""
        task = "solve"
        [scene]
        mass = 1.0
        velocities = [1.0]
        [scene.potential]
        family = "expression"
        U = "k*q**2/2 + q**4/4"
        params = {{ k = 1.0 }}
        [sweep]
        "potential.params.k" = [1.0, 2.0, -1.0]
        mass = {masses}
        """
    )
    seen = []
    spec = parse_spec(spec_text, "<many>", progress=lambda done, total: seen.append((done, total)))
    assert len(spec.cases) == 900 and len(spec.invalid) == 300
    assert sorted(built) == sorted(set(built)) and len(built) == 3, (
        f"got {len(built)} potential validations, should be 3 (one per distinct table)"
    )
    assert "potential.params.k" in spec.invalid[0].error or "k" in spec.invalid[0].error
    assert spec.invalid[0].error.startswith(f"scene case {spec.invalid[0].index} ("), (
        f"got {spec.invalid[0].error!r}, should name its own case"
    )
    assert seen[-1] == (900, 900) and len(seen) == 901, "got no progress while validating"


def test_turning_points_are_searched_from_the_top_energy_down(monkeypatch):
    """One search per potential, plus one per case that has no turning point.

    U = 1 - exp(-q) never exceeds 1 J: the cases with E = m v0^2 / 2 >= 1 J have no
    turning point and must be invalid with their own reason; every lower energy is
    then known to have one (U rises continuously from 0), so it is not searched again.
    """
    from reference_impl.potentials import base

    calls = []
    real = base.Potential.turning_point

    def counting(self, E, **kw):
        calls.append(E)
        return real(self, E, **kw)

    monkeypatch.setattr(base.Potential, "turning_point", counting)
    # E = 0.275 ... 1.525 J, never exactly 1 J (where the turning point is at infinity)
    masses = [round(0.55 + 0.1 * i, 2) for i in range(26)]
    spec = spec_from_dict(
        {
            "task": "solve",
            "scene": {
                "mass": 1.0,
                "velocities": [1.0],
                "potential": {"family": "expression", "U": "1 - exp(-q)"},
            },
            "sweep": {"mass": masses},
        }
    )
    invalid = [c.params["mass"] for c in spec.cases if c.error]
    assert invalid == [m for m in masses if m / 2 > 1.0], (
        f"got invalid masses {invalid}, should be those with E >= 1 J [issue 22, validation]"
    )
    assert all("velocity 1 m/s" in c.error for c in spec.cases if c.error)
    assert len(calls) == len(invalid) + 1, (
        f"got {len(calls)} turning-point searches, should be {len(invalid) + 1}"
    )


# --------------------------------------------------------------------------
# cases run in this process
# --------------------------------------------------------------------------
def test_task_timeout_and_task_rows_in_process():
    """The dt-crit task honours its deadline; solve and bench give one row per speed."""
    scene = {
        "name": "h",
        "mass": 1.0,
        "velocities": [1.0, 2.0],
        "kind": "impact",
        "potential": {"family": "power", "k": 1.0, "p": 1.5},
    }
    with pytest.raises(CaseTimeout):
        run_case(
            {"key": "k", "task": "dt-crit", "criterion": None, "scene": scene, "timeout": 1e-9}
        )
    rows = run_case(
        {"key": "k", "task": "solve", "criterion": None, "scene": scene, "timeout": 60.0}
    )
    assert_true(
        [r["v0"] for r in rows] == [1.0, 2.0] and all("restitution" in r for r in rows),
        got=str(rows)[:200],
        should="one solve row per speed",
        claim="sweep",
        call="run_case solve",
    )
    rows = run_case(
        {
            "key": "k",
            "task": "bench:reference",
            "criterion": None,
            "scene": {**scene, "velocities": [1.0]},
            "timeout": 60.0,
        }
    )
    assert_true(
        len(rows) >= 1
        and rows[0]["status"] in ("pass", "fail")
        and "measured.restitution" in rows[0],
        got=str(rows)[:300],
        should="bench rows with flattened measurements",
        claim="sweep",
        call="run_case bench:reference",
    )


def test_report_map_through_run_cases_equals_dt_crit_map():
    """The bridge the report's map uses gives dt_crit_map's table, and its cases pickle."""
    import pickle

    from reference_impl.studies.dtcrit_map import coverage, dt_crit_map
    from reference_impl.sweep import dt_crit_map_on_cluster

    cases = [c for c in coverage(quick=True) if c.family != "power"]
    pickle.loads(pickle.dumps(cases))  # what a worker receives
    want = dt_crit_map(cases, kinds=("impact",))
    got = dt_crit_map_on_cluster(cases, kinds=("impact",), workers=0)
    assert_true(
        got.equals(want),
        got=f"{len(got)} rows, columns {list(got.columns)[:4]}",
        should=f"the {len(want)} rows of dt_crit_map",
        claim="sweep",
        call="dt_crit_map_on_cluster(workers=0)",
    )
