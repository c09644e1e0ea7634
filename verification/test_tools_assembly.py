"""The assembly instruments (issue 39, sections 3 and 5): lanes, ensembles, Delta t_safe
conventions, the tangent step, every registered family, and ``hcv dt-crit --json`` on a
chain; each against a reference computed here."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from reference_impl.assembly import geometry
from reference_impl.assembly.lanes import AssemblyModel, initial_energy, run_lanes
from reference_impl.assembly.linear import dt_crit_linear
from reference_impl.assembly.safe import dt_safe_conventions, tangent_step
from reference_impl.assembly.search import assembly_report, search_ensemble
from reference_impl.errors import HCVInputError
from reference_impl.potentials import FAMILIES, Expression, PowerLaw
from reference_impl.scenes import load_scene
from reference_impl.scenes._catalogue import catalogue_rows
from reference_impl.stability.bound import dt_safe
from reference_impl.stability.criteria import EnergyGrowth, SearchGrid
from verification._hcv_run import hcv
from verification.assertions import assert_close, assert_true

_TOOL = "tool"
_HERTZ = PowerLaw(1.0879e10, 1.5)
_M = 4.1103e-3
# A coarse scan and short horizon: these tests check the ensemble's bookkeeping, not a verdict.
_GRID = SearchGrid(lo=0.05, hi=2.0, step=0.05, resolution=1e-2, refine_points=4)
_CRIT = EnergyGrowth(factor=100.0, n_steps=400, confirm_factor=1e4, confirm_horizon=2)


def _chain(n: int, pot=_HERTZ, m: float = _M, v0: float = 1.0) -> AssemblyModel:
    asm = geometry.chain([m] * n, "both", 0.0)
    v = np.zeros((n, 1))
    v[0, 0] = v0
    return AssemblyModel(asm, pot, False, 0.0, 0.0, v, np.zeros((n, 0)))


def test_lanes_whose_velocities_differ_in_the_last_bit_part_ways():
    """The ensemble's perturbation reaches the dynamics: same step, 1 ulp apart, different
    energies after a few hundred steps of a three-sphere chain."""
    model = _chain(3)
    ref = dt_safe(_HERTZ, _M, 1.0).dt_safe
    out = run_lanes(model, [0.3 * ref] * 2, [1.0, 1.0 + 2.0**-52], factor=1e6,
                    confirm_level=1e6, n_steps=400, confirm_steps=400)  # fmt: skip
    assert_true(
        out.e_end[0] != out.e_end[1] and np.all(out.status == 1),
        got=f"E_end {out.e_end.tolist()}, status {out.status.tolist()}",
        should="two completed lanes with different final energies",
        claim=_TOOL,
        call="run_lanes(vscale=[1, 1 + 2^-52])",
    )


def test_ensemble_distribution_is_the_lanes_own():
    """Quantiles are lane values in order; P_fail(dt) is the lanes' empirical CDF."""
    model = _chain(3)
    ref = dt_safe(_HERTZ, _M, 1.0).dt_safe
    ens = search_ensemble(model, ref, n_lanes=32, criterion=_CRIT, grid=_GRID)
    d = np.sort(ens.dt_crit)
    q = ens.quantiles()
    pf = ens.p_fail()
    cdf_ok = all(abs(p - np.count_nonzero(ens.dt_crit <= x) / 32) < 1e-15 or x == pf[k + 1][0]
                 for k, (x, p) in enumerate(pf[:-1]))  # fmt: skip
    assert_true(
        ens.dt_crit.size == 32 and np.all(np.isfinite(d)) and q["5"] <= q["50"] <= q["95"]
        and {q["5"], q["50"], q["95"]} <= set(d.tolist()) and cdf_ok and pf[-1][1] == 1.0
        and np.all(ens.dt_stable < ens.dt_crit),
        got=f"quantiles {q}, P_fail {pf[:3]}..., dt_crit {d[:3]}",
        should="lane values in order, an empirical CDF ending at 1, brackets below each failure",
        claim=_TOOL,
        call="search_ensemble(chain 3, 32 lanes)",
    )  # fmt: skip


def test_dt_safe_conventions_use_the_striker_its_partner_and_all_the_energy():
    model = _chain(4, v0=0.7)
    e0 = initial_energy(model)
    got = dt_safe_conventions(model, e0)
    m_red = _M / 2  # equal spheres
    want = {
        "paper": dt_safe(_HERTZ, _M, 0.7).dt_safe,
        "reduced": dt_safe(_HERTZ, m_red, 0.7).dt_safe,
        "one_contact": dt_safe(_HERTZ, m_red, math.sqrt(2 * 0.5 * _M * 0.49 / m_red)).dt_safe,
    }
    assert_close([got[k] for k in want], [want[k] for k in want], rtol=1e-12, claim=_TOOL,
                 call="dt_safe_conventions(chain 4, v0 0.7)")  # fmt: skip
    assert_close(e0, 0.5 * _M * 0.49, rtol=1e-15, claim=_TOOL, call="initial_energy")


def test_tangent_step_of_a_linear_assembly_is_its_critical_step():
    """U'' = k everywhere: the tangent-stiffness step is 2 / omega_max exactly."""
    asm = geometry.lattice("triangular", 3, 0.01, 0.005)
    assert_close(tangent_step(asm, PowerLaw(1e6, 1.0), 1e-6), dt_crit_linear(asm, 1e6),
                 rtol=1e-12, claim=_TOOL, call="tangent_step(triangular, linear)")  # fmt: skip


def _family_example(family: str):
    """(potential, mass, speed) of the first catalogue scene of ``family``."""
    for row in catalogue_rows():
        if row["family"] == family and row["kind"] not in ("chain", "lattice"):
            s = load_scene(row["name"])
            return s.potential, s.mass, s.velocities[0]
    return None


@pytest.mark.parametrize("family", sorted(FAMILIES))
def test_every_registered_family_runs_in_a_chain(family):
    """Each family's catalogue law between three bodies: lanes run, energy is kept (a small
    step: Verlet's energy error ~ (omega dt)^2, here below 1e-2 of E_0)."""
    example = _family_example(family)
    assert example is not None, f"got no catalogue scene of {family}, should be one [tool]"
    pot, m, v0 = example
    model = _chain(3, pot, m, v0)
    q_max = pot.turning_point(0.5 * m * v0 * v0)
    ref = dt_safe(pot, m, v0).dt_safe or 2 * q_max / v0 * 1e-2
    out = run_lanes(model, [0.05 * ref], 1.0, factor=1.5, confirm_level=1.5,
                    n_steps=2000, confirm_steps=2000)  # fmt: skip
    drift = abs(out.e_end[0] / out.e0[0] - 1)
    assert_true(
        out.status[0] == 1 and drift < 1e-2 and out.q_max[0] > 0,
        got=f"status {out.status[0]}, |E_end/E_0 - 1| = {drift:.3g}, q_max {out.q_max[0]:.3g}",
        should="completed, energy kept to 1e-2, contacts closed",
        claim=_TOOL,
        call=f"run_lanes(chain of 3, {family})",
    )


def test_a_law_without_a_term_table_is_refused_in_one_line():
    model = _chain(2, Expression("q**2*exp(q)"), 1.0, 1.0)
    with pytest.raises(HCVInputError, match="term table") as info:
        run_lanes(model, [1e-3], 1.0, factor=2, confirm_level=2, n_steps=1, confirm_steps=1)
    assert "\n" not in str(info.value)


def test_report_flags_and_factor_follow_from_its_quantiles():
    rep = assembly_report(_chain(2), horizons=(200, 800), n_lanes=32, grid=_GRID)
    rows = rep["by_horizon"]
    paper = rep["dt_safe"]["paper"]
    first, last = rows[0]["dt_crit_quantiles"], rows[-1]["dt_crit_quantiles"]
    assert_true(
        [r["horizon"] for r in rows] == [200, 800]
        and rep["horizon_dependent"] == (last["50"] < first["5"])
        and rep["holds"] == all(r["dt_crit_quantiles"]["5"] >= paper for r in rows)
        and rep["factor"] == last["5"] / paper
        and rep["n_bodies"] == 2 and rep["coordination"] == 2.0,
        got=json.dumps({k: rep[k] for k in ("horizon_dependent", "holds", "factor")}),
        should="the flags and factor of the stated rules",
        claim=_TOOL,
        call="assembly_report(chain 2)",
    )  # fmt: skip


def test_hcv_dt_crit_json_on_a_chain(tmp_path):
    path = tmp_path / "c.toml"
    path.write_text(
        'kind = "chain"\nn = 2\nmass = 4.1103e-3\nwalls = "both"\nvelocities = 1.0\n'
        '[potential]\nfamily = "power"\nk = 1.0879e10\np = 1.5\n'
    )
    r = hcv(["dt-crit", str(path), "--json", "--horizons", "200,400", "--lanes", "4"],
            cwd=tmp_path, timeout=600)  # fmt: skip
    doc = json.loads(r.stdout) if r.returncode == 0 else {}
    rep = doc.get("assembly", {})
    keys = {"dt_safe", "by_horizon", "horizon_dependent", "holds", "factor", "n_lanes"}
    row_keys = {"dt_crit_quantiles", "p_fail", "dt_tangent", "dt_crit_lane0", "horizon"}
    assert_true(
        keys <= set(rep) and all(row_keys <= set(x) for x in rep.get("by_horizon", []))
        and set(rep.get("dt_safe", {})) == {"paper", "reduced", "one_contact"}
        and rep.get("n_lanes") == 4,
        got=f"exit {r.returncode}, keys {sorted(rep)}, stderr {r.stderr[-200:]!r}",
        should=f"exit 0 and {sorted(keys)}, rows with {sorted(row_keys)}",
        claim=_TOOL,
        call="hcv dt-crit c.toml --json --horizons 200,400 --lanes 4",
    )  # fmt: skip


@pytest.mark.parametrize(
    "args, needle",
    [(["--horizons", bad], "--horizons") for bad in ("0", "1.5", "1e9", "nan", "x,1")]
    + [(["--lanes", "0"], "n_lanes"), (["--criterion", "n_steps=10"], "--horizons")],
)
def test_bad_ensemble_options_are_one_line_exit_2(tmp_path, args, needle):
    r = hcv(["dt-crit", "chain-linear", "--horizons", "100", *args], cwd=tmp_path)
    assert_true(
        r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1 and needle in r.stderr
        and not r.stdout,
        got=f"exit {r.returncode}, stderr {r.stderr!r}",
        should=f"exit 2, one line naming {needle}, no output",
        claim=_TOOL,
        call=f"hcv dt-crit chain-linear {' '.join(args)}",
    )  # fmt: skip
