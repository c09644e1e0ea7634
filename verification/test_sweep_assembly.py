"""Assembly ensembles through ``hcv sweep`` (issue 39 section 5): groups of lanes as cases.

A dt-crit sweep of chain or lattice scenes runs each ensemble in groups of lanes, one case
(one Dask task) per horizon and group (`reference_impl.sweep._assembly`). The groups must
give the whole ensemble's lanes bit for bit (the spread of an ensemble is the measurement),
the spec must expand into the stated cases, and a bad ``[assembly]`` table is one line,
exit status 2, nothing run. Fast: two- and three-body chains at 1000 and 3000 steps, run
serially through `run_case` (the engine's function; Dask itself is tested in
test_sweep_cluster.py).
"""

from __future__ import annotations

import pandas as pd
import pytest

from reference_impl.cli import main
from reference_impl.scenes import scene_from_dict
from reference_impl.sweep import SweepSpecError, _runner, parse_spec, run_case
from reference_impl.sweep._assembly import ensemble_rows
from reference_impl.tasks import search_assembly_scene
from verification.assertions import assert_true

CLAIM = "sweep assembly"
_SCENE = """
[scene]
name = "c"
kind = "chain"
n = 2
mass = 4.1103e-3
walls = "both"
velocities = 1.0
[scene.potential]
family = "power"
k = 1.0879e10
p = 1.5
"""
_ASSEMBLY = "[assembly]\nhorizons = [1000, 3000]\nlanes = 8\nlane_group = 3\n"


def _spec(assembly: str = _ASSEMBLY, sweep: str = "n = [2, 3]", task: str = "dt-crit") -> str:
    return f'task = "{task}"\n{assembly}{_SCENE}[sweep]\n{sweep}\n'


def test_the_spec_expands_into_groups_of_lanes_per_horizon():
    """2 chains x 2 horizons x ceil(8 / 3) = 3 groups: 12 cases, lanes 0-2, 3-5, 6-7."""
    spec = parse_spec(_spec(), "spec")
    got = [
        (c.params["n"], c.params["assembly.horizon"], c.code["assembly"]["first_lane"],
         c.code["assembly"]["n_lanes"])
        for c in spec.cases
    ]  # fmt: skip
    want = [(n, h, a, k) for n in (2, 3) for h in (1000, 3000) for a, k in ((0, 3), (3, 3), (6, 2))]
    assert_true(
        got == want and len({c.key for c in spec.cases}) == len(want),
        got=f"{got}, {len({c.key for c in spec.cases})} distinct keys",
        should=f"{want}, each its own key",
        claim=CLAIM,
        call="parse_spec(chain, [assembly] lanes 8, lane_group 3)",
    )


def test_groups_of_lanes_give_the_whole_ensemble_bit_for_bit():
    """Per chain and horizon: the lanes of the groups are the ensemble's (`hcv dt-crit`'s
    search_assembly_scene), so the 5 / 50 / 95 % points agree exactly."""
    spec = parse_spec(_spec(), "spec")
    rows = [{**c.params, **r} for c in spec.cases for r in run_case(c.payload())]
    table = ensemble_rows(pd.DataFrame(rows), ["n"])
    wrong = []
    for n in (2, 3):
        scene = scene_from_dict({**spec.cases[0].scene, "n": n}, "chain")
        whole = search_assembly_scene(scene, [1000, 3000], 8)
        for hr in whole["by_horizon"]:
            got = table[(table["n"] == n) & (table["horizon"] == hr["horizon"])].iloc[0]
            mine = {p: float(got[f"dt_crit_{p}"]) for p in ("5", "50", "95")}
            if mine != hr["dt_crit_quantiles"] or got["lanes_found"] != 8:
                wrong.append((n, hr["horizon"], mine, hr["dt_crit_quantiles"]))
    assert_true(
        not wrong,
        got=f"(n, horizon, groups' points, whole ensemble's) {wrong}",
        should="identical points from all 8 lanes",
        claim=CLAIM,
        call="run_case(groups of 3 lanes) vs search_assembly_scene(8 lanes)",
    )


def test_one_group_of_all_lanes_at_one_horizon_is_one_case_per_scene():
    """lane_group = lanes and one horizon: each scene one case (the whole ensemble)."""
    spec = parse_spec(_spec("[assembly]\nhorizons = [1000]\nlanes = 4\nlane_group = 4\n"), "s")
    got = [(c.params["n"], c.code["assembly"]["n_lanes"]) for c in spec.cases]
    assert_true(
        got == [(2, 4), (3, 4)],
        got=str(got),
        should="[(2, 4), (3, 4)]",
        claim=CLAIM,
        call="parse_spec([assembly] horizons [1000], lanes 4, lane_group 4)",
    )


def test_a_single_contact_sweep_is_not_grouped():
    """A dt-crit sweep of impact scenes keeps its cases as they were (no assembly params)."""
    text = (
        'task = "dt-crit"\n[scene]\nname = "h"\nmass = 1.0\nvelocities = [1.0]\n'
        '[scene.potential]\nfamily = "power"\nk = 1.0\np = 1.5\n[sweep]\n'
        '"potential.p" = [1.5, 2.0]\n'
    )
    spec = parse_spec(text, "spec")
    assert_true(
        len(spec.cases) == 2 and all("assembly" not in c.code for c in spec.cases),
        got=f"{len(spec.cases)} cases, codes {[c.code for c in spec.cases]}",
        should="2 cases without an assembly group",
        claim=CLAIM,
        call="parse_spec(impact dt-crit)",
    )


_BAD = [
    (_spec("[assembly]\nlanes = 0\n"), "assembly.lanes"),
    (_spec("[assembly]\nlane_group = 'x'\n"), "assembly.lane_group"),
    (_spec("[assembly]\nhorizons = []\n"), "assembly.horizons"),
    (_spec("[assembly]\nhorizons = [1e8]\n"), "assembly.horizons"),
    (_spec("[assembly]\nlane = 4\n"), "assembly.lane"),
    (_spec(task="solve"), "[assembly] applies to task = 'dt-crit'"),
    (
        _spec().replace('kind = "chain"\nn = 2\n', "").replace("walls = \"both\"\n", "")
        .replace("n = [2, 3]", "mass = [1.0, 2.0]"),
        "[assembly] applies to chain and lattice",
    ),
]  # fmt: skip


@pytest.mark.parametrize(("text", "needle"), _BAD)
def test_a_bad_assembly_table_is_one_line_exit_2(tmp_path, monkeypatch, capsys, text, needle):
    started = []
    monkeypatch.setattr(_runner, "open_client", lambda *a, **k: started.append("cluster"))
    path = tmp_path / "bad.toml"
    path.write_text(text, encoding="utf-8")
    out = tmp_path / "out"
    with pytest.raises(SweepSpecError):
        parse_spec(text, "bad")
    code = main(["sweep", str(path), "--workers", "1", "--out", str(out)])
    lines = capsys.readouterr().err.strip().splitlines()
    assert_true(
        code == 2 and len(lines) == 1 and needle in lines[0] and not started
        and not out.exists(),
        got=f"exit {code}, stderr {lines}, cluster {started}, DIR made {out.exists()}",
        should=f"exit 2, one line naming {needle!r}, nothing started or written",
        claim=CLAIM,
        call=f"hcv sweep ({needle})",
    )  # fmt: skip


@pytest.mark.skipif(not _runner.dask_available(), reason="needs the sweep extra (Dask)")
def test_hcv_sweep_writes_lane_rows_and_the_ensembles_table(tmp_path, capsys):
    """End to end on one local worker: a row per lane in results.parquet, one line per
    ensemble (scene and horizon) in summary.md, every lane found."""
    text = _spec("[assembly]\nhorizons = [500, 1000]\nlanes = 4\nlane_group = 2\n", "n = [2]")
    path = tmp_path / "spec.toml"
    path.write_text(text, encoding="utf-8")
    out = tmp_path / "out"
    code = main(["sweep", str(path), "--workers", "1", "--out", str(out)])
    df = pd.read_parquet(out / "results.parquet")
    summary = (out / "summary.md").read_text()
    table = summary.split("## Ensembles")[1].split("\n## ")[0] if "## Ensembles" in summary else ""
    ens_lines = [x for x in table.splitlines() if x.startswith("| 2 |")]
    assert_true(
        code == 0 and len(df) == 8 and sorted(df["lane"]) == [0, 0, 1, 1, 2, 2, 3, 3]
        and len(ens_lines) == 2 and all("| 4 | 4 |" in x for x in ens_lines),
        got=f"exit {code}, {len(df)} rows, lanes {sorted(df.get('lane', []))}, ensemble "
        f"lines {ens_lines}, stderr {capsys.readouterr().err[-300:]!r}",
        should="exit 0, 8 lane rows (lanes 0-3 at 2 horizons), 2 ensemble lines of 4 of 4 lanes",
        claim=CLAIM,
        call="hcv sweep (chain, 2 horizons, 4 lanes in groups of 2) --workers 1",
    )  # fmt: skip


# ------------------------------------------------------------------ progress (issue 39 §5)
def test_hcv_dt_crit_says_each_horizon_off_a_terminal(capsys):
    """A log (stderr not a terminal) gets a line as each horizon starts, naming it, and one
    at the end: not only the result."""
    code = main(["dt-crit", "chain-hertz", "--horizons", "500,1000", "--lanes", "2", "--json"])
    err = capsys.readouterr().err.strip().splitlines()
    starts = [x for x in err if x.startswith("dt-crit: horizon ")]
    assert_true(
        code == 0
        and any("horizon 1 of 2 (500 steps)" in x for x in starts)
        and any("horizon 2 of 2 (1,000 steps)" in x for x in starts)
        and err[-1].startswith("dt-crit: all 2 horizons done"),
        got=f"exit {code}, stderr {err}",
        should="exit 0, a line for horizon 1 of 2 (500 steps), one for 2 of 2 (1,000 steps), "
        "and 'all 2 horizons done' last",
        claim=CLAIM,
        call="hcv dt-crit chain-hertz --horizons 500,1000 --lanes 2 --json",
    )


def test_a_round_reports_progress_between_kernel_calls(monkeypatch):
    """Within a round (all lanes run one horizon) the search calls back between the kernel's
    calls, not only when the round ends: a long horizon shows progress and a sweep case's
    deadline is checked. Kernel calls are made small here so that a round takes many."""
    from reference_impl.assembly import lanes as lanes_mod
    from reference_impl.assembly.model import assembly_model
    from reference_impl.assembly.search import reference_step, search_ensemble
    from reference_impl.scenes import load_scene
    from reference_impl.stability.criteria import EnergyGrowth

    model = assembly_model(load_scene("chain-hertz"))
    _, _, ref = reference_step(model)
    calls = []
    monkeypatch.setattr(lanes_mod, "_CALL_UPDATES", 1 << 12)  # ~4000 updates a call
    crit = EnergyGrowth(factor=100.0, n_steps=2000, confirm_factor=1e4, confirm_horizon=2)
    search_ensemble(model, ref, n_lanes=2, criterion=crit, progress=lambda d, t: calls.append(d))
    repeats = sum(a == b for a, b in zip(calls, calls[1:], strict=False))
    assert_true(
        repeats > 10 and calls[-1] == 2.0,
        got=f"{len(calls)} calls, {repeats} repeating the round's value, last {calls[-1:]}",
        should="many calls between kernel calls (> 10 repeats), the last 2.0 (both lanes done)",
        claim=CLAIM,
        call="search_ensemble(chain-hertz, 2 lanes, 2000 steps, small kernel calls)",
    )
