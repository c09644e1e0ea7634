"""The contact codes on chain scenes (issue 39, section 4; contract item 14).

Without a code: the contract's default declines in one line, a malformed chain run is
refused, the suite's energy of a chain and its runaway verdict on a series. With LIGGGHTS
and YADE (marked with their codes' markers, skipped with the install line where absent):
the code's positions after a few hundred steps are those of an independent velocity
Verlet of the scene's law (which checks the mapping of k on the walls and between the
spheres, and the scheme), its measured Delta t_crit lies within the suite's own ensemble
of the same scene, horizon, rule and grid, and its advice is what the code computes
whatever step it is asked at. ``hcv dt-crit SCENE --adapter CODE``: the decline and a
lattice the codes do not run are one line and exit status 2 (the lattices the codes run:
`verification/test_assembly_codes_lattice.py`).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from reference_impl.adapters._assembly_request import chain_energy, chain_run_from_mapping
from reference_impl.adapters.base import (
    AdapterDeclined,
    AdapterOutputError,
    ChainRequest,
    ChainRun,
    ContactAdapter,
)
from reference_impl.bench._code_worker import RUN_TIMEOUT_S
from reference_impl.bench.assembly_codes import assembly_codes_table, chain_scene, judge_energy
from reference_impl.bench.scorecard.tolerances import default_tolerances
from reference_impl.cli import _parser
from reference_impl.potentials.power import PowerLaw
from reference_impl.stability.criteria import EnergyGrowth
from verification._assembly_codes import (
    CLAIM,
    K,
    M,
    R,
    assert_advice_is_the_codes,
    assert_dt_crit_in_suite_ensemble,
    assert_run_is_verlet,
    code_fixture,
    dt_safe,
    needs,
    verlet_chain,
)
from verification._hcv_run import hcv

from .assertions import assert_close, assert_true

# Short runs of the position check: 300 steps at 0.05 Delta t_safe cover the striker's
# contact, the pulse through the chain and the right wall's contact.
STEPS, DT_FRACTION = 300, 0.05
# Positions agree to 1e-12 m: the codes print 15 significant digits (x ~ 1e-2 m: 1e-17 m)
# and round-off grows over 300 steps to ~1e-15 m; a wrong k on the walls (Hertz on a wall
# of the spheres' material is sqrt(2) stiffer) moves them by ~1e-6 m.
X_TOL = 1e-12
# Velocities agree to 1e-9 m/s of speeds ~1 m/s: 15 printed digits and the round-off of 300
# steps.
V_TOL = 1e-9


def _request(n: int, dt: float, steps: int, walls: str = "both") -> ChainRequest:
    return ChainRequest("t", PowerLaw(K, 1.5), (M,) * n, R, walls, (1.0,) + (0.0,) * (n - 1),
                        dt, steps)  # fmt: skip


def _dt_safe(n: int) -> float:
    return dt_safe(chain_scene(n))


# -- the contract, without a code ---------------------------------------------------------


def test_default_adapter_declines_assembly_in_one_line():
    class Plain(ContactAdapter):
        name = "plain"

    with pytest.raises(AdapterDeclined) as exc:
        Plain().assembly(_request(2, 1e-7, 10))
    assert_true(exc.value.declined == "plain does not run assembly scenes",
                got=repr(exc.value.declined), should="'plain does not run assembly scenes'",
                claim=CLAIM, call="ContactAdapter.assembly")  # fmt: skip


def test_malformed_chain_run_is_refused():
    req = _request(3, 1e-7, 10)
    with pytest.raises(AdapterOutputError, match=r"shape \(samples, 3\)"):
        chain_run_from_mapping({"x": np.zeros((5, 2)), "v": np.zeros((5, 2))}, req, "c")
    with pytest.raises(AdapterOutputError, match="returned 12 samples"):
        chain_run_from_mapping({"x": np.zeros((12, 3)), "v": np.zeros((12, 3))}, req, "c")


def test_chain_energy_is_kinetic_plus_hertz_of_every_contact():
    req = _request(2, 1e-7, 1)  # walls at x = 0 and x = 4 R
    q_left, q_mid = 1e-6, 2e-6  # overlaps (m); the right wall then has a gap of their sum
    x0 = R - q_left
    x1 = x0 + 2 * R - q_mid
    x = np.array([req.x0(), [x0, x1]])
    v = np.array([[1.0, 0.0], [0.5, -0.25]])
    e = chain_energy(req, ChainRun(x, v))
    u = K / 2.5 * (q_left**2.5 + q_mid**2.5)  # U = k q^(5/2) / (5/2); a gap has none
    # 1e-9: the overlaps come from differences of positions ~1e-2 m (round-off 1e-18 m
    # on overlaps of 1e-6 m: 1e-12), to the power 5/2
    assert_close(e[1], 0.5 * M * (0.5**2 + 0.25**2) + u, rtol=1e-9, claim=CLAIM,
                 call="chain_energy (3 contacts)")  # fmt: skip
    assert_close(e[0], 0.5 * M, rtol=1e-15, claim=CLAIM, call="chain_energy (start)")


def test_judge_energy_follows_the_kernels_rule():
    crit = EnergyGrowth(factor=100.0, n_steps=10, confirm_factor=10.0, confirm_horizon=3)
    flat = np.ones(11)
    assert judge_energy(flat, crit)[:2] == (False, None)
    runaway = np.concatenate([np.ones(5), [200.0, 2e3, 2e4], np.ones(3)])
    assert judge_energy(runaway, crit)[:2] == (True, "confirmed")
    blown = np.concatenate([np.ones(5), [np.nan] * 6])
    assert judge_energy(blown, crit)[:2] == (True, "domain")
    # crossed once within the horizon: undecided until the confirmation horizon is run
    crossed = np.concatenate([np.ones(5), [200.0], np.ones(5)])
    assert judge_energy(crossed, crit)[3] is True
    bounded = np.concatenate([np.ones(5), [200.0], np.ones(25)])
    failed, evidence, peak, more = judge_energy(bounded, crit)
    assert (failed, evidence, more) == (False, None, False)
    assert_close(peak, 200.0, rtol=0, claim=CLAIM, call="judge_energy (bounded peak)")


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["chain-hertz", "--adapter", "reference"], "reference does not run assembly scenes"),
        (["lattice-hertz-triangular", "--adapter", "reference"],
         "the codes run lattices with a rectangular periodic box"),
        (["lattice-fcc-rotation", "--adapter", "reference"],
         "tangential_ratio 0.5 and rotation True are declined"),
        (["hertz", "--adapter", "reference"], "--adapter runs chain and lattice scenes only"),
        (["chain-hertz", "--adapter", "reference", "--horizons", "10,20"],
         "--adapter takes one horizon, got --horizons [10, 20]"),
        (["chain-hertz", "--adapter", "nosuchcode"], "nosuchcode"),
    ],
)  # fmt: skip
def test_hcv_dt_crit_adapter_refusals_are_one_line_exit_2(args, words, tmp_path):
    r = hcv(["dt-crit", *args], cwd=tmp_path)
    lines = r.stderr.strip().splitlines()
    assert_true(r.returncode == 2 and len(lines) == 1 and words in lines[0] and not r.stdout,
                got=f"exit {r.returncode}, stderr {r.stderr!r}, stdout {r.stdout[:80]!r}",
                should=f"exit 2 and one line with {words!r}", claim=CLAIM,
                call=f"hcv dt-crit {' '.join(args)}")  # fmt: skip


def test_hcv_dt_crit_runs_a_third_party_chain_code(tmp_path):
    spec = "verification._assembly_codes:VerletChainCode"
    r = hcv(["dt-crit", "chain-hertz", "--adapter", spec, "--json", "--horizons", "500"],
            cwd=tmp_path)  # fmt: skip
    assert_true(
        r.returncode == 0,
        got=f"exit {r.returncode}: {r.stderr[-300:]!r}",
        should="exit 0",
        claim=CLAIM,
        call=f"hcv dt-crit chain-hertz --adapter {spec}",
    )
    rep = json.loads(r.stdout)["code"]
    (advice,) = rep["advice"]
    # the verdict is the comparison it says: safe when the advice is <= dt_crit, and the
    # factor dt_crit / advice (to round-off of the division)
    assert_true(advice["safe"] == (advice["dt"] <= rep["dt_crit"])
                and 0 < rep["dt_crit"] < math.inf and rep["evidence"] == "confirmed",
                got=repr(rep), should="a confirmed finite dt_crit and the advice's verdict",
                claim=CLAIM, call=f"hcv dt-crit --adapter {spec}")  # fmt: skip
    assert_close(advice["factor"], rep["dt_crit"] / advice["dt"], rtol=1e-15, claim=CLAIM,
                 call=f"hcv dt-crit --adapter {spec} factor")  # fmt: skip


@pytest.mark.parametrize(
    ("cls", "words"),
    [("CrashingChainCode", "segmentation fault (simulated)"),
     ("MalformedChainCode", "shape (samples, 10)"),
     ("QuittingChainCode", "not past the stop energy")],
)  # fmt: skip
def test_hcv_dt_crit_chain_code_that_fails_is_one_line_exit_1(cls, words, tmp_path):
    spec = f"verification._assembly_codes:{cls}"
    r = hcv(["dt-crit", "chain-hertz", "--adapter", spec], cwd=tmp_path)
    lines = r.stderr.strip().splitlines()
    assert_true(r.returncode == 1 and len(lines) == 1 and words in lines[0] and not r.stdout,
                got=f"exit {r.returncode}, stderr {r.stderr[-300:]!r}",
                should=f"exit 1 and one line with {words!r}", claim=CLAIM,
                call=f"hcv dt-crit chain-hertz --adapter {spec}")  # fmt: skip


@pytest.mark.parametrize(
    ("cls", "name", "sig"),
    [("AbortingChainCode", "aborting-chain", "SIGABRT"),
     ("SegfaultingChainCode", "segfaulting-chain", "SIGSEGV")],
)  # fmt: skip
def test_hcv_dt_crit_code_that_kills_its_process_is_one_line_exit_1(cls, name, sig, tmp_path):
    """A code that asks for isolation runs in a bench worker process, as ``hcv bench`` runs
    it: its abort or segfault ends the worker, and hcv says so in one line naming the code."""
    spec = f"verification._assembly_codes:{cls}"
    r = hcv(["dt-crit", "chain-hertz", "--adapter", spec], cwd=tmp_path)
    lines = r.stderr.strip().splitlines()
    words = f"{name} failed: crashed (killed by signal"
    assert_true(r.returncode == 1 and len(lines) == 1 and words in lines[0]
                and sig in lines[0] and not r.stdout,
                got=f"exit {r.returncode}, stderr {r.stderr[-300:]!r}",
                should=f"exit 1 and one line with {words!r} and {sig}", claim=CLAIM,
                call=f"hcv dt-crit chain-hertz --adapter {spec}")  # fmt: skip


def test_hcv_dt_crit_kills_a_code_at_its_timeout_in_one_line_exit_2(tmp_path):
    """An isolated code whose run never ends: at ``--timeout`` its worker process is
    killed and hcv stops with one line "... timed out after N s", exit status 2 (on main
    there was no --timeout and no limit: the run waited for the code forever)."""
    spec = "verification._assembly_codes:SleepingChainCode"
    r = hcv(["dt-crit", "chain-hertz", "--adapter", spec, "--timeout", "1"], cwd=tmp_path)
    lines = r.stderr.strip().splitlines()
    pid_file = tmp_path / "sleeping-chain.pid"
    pid = pid_file.read_text() if pid_file.exists() else None
    # hcv has exited: the killed worker was reaped, no process with its id is left
    alive = pid is not None and Path(f"/proc/{pid}").exists()
    words = "sleeping-chain timed out after 1 s"
    assert_true(r.returncode == 2 and len(lines) == 1 and words in lines[0] and not r.stdout
                and pid is not None and not alive,
                got=f"exit {r.returncode}, stderr {r.stderr[-300:]!r}, worker {pid} alive {alive}",
                should=f"exit 2, one line with {words!r}, the worker gone", claim=CLAIM,
                call=f"hcv dt-crit chain-hertz --adapter {spec} --timeout 1")  # fmt: skip


@pytest.mark.parametrize(
    ("args", "words"),
    [(["--timeout", "0"], "--timeout: '0' is not in (0, 86400] seconds"),
     (["--timeout", "nan"], "--timeout: 'nan' is not in (0, 86400] seconds"),
     (["--timeout", "1e6"], "--timeout: '1e6' is not in (0, 86400] seconds"),
     (["--timeout", "soon"], "--timeout: 'soon' is not a number of seconds")],
)  # fmt: skip
def test_hcv_dt_crit_refuses_a_bad_timeout_before_any_code_runs(args, words, tmp_path):
    spec = "verification._assembly_codes:SleepingChainCode"
    r = hcv(["dt-crit", "chain-hertz", "--adapter", spec, *args], cwd=tmp_path)
    lines = r.stderr.strip().splitlines()
    assert_true(r.returncode == 2 and len(lines) == 1 and words in lines[0]
                and not (tmp_path / "sleeping-chain.pid").exists(),
                got=f"exit {r.returncode}, stderr {r.stderr[-300:]!r}",
                should=f"exit 2, one line with {words!r}, no run started", claim=CLAIM,
                call=f"hcv dt-crit --adapter {spec} {' '.join(args)}")  # fmt: skip


def test_hcv_dt_crit_refuses_a_timeout_without_a_code(tmp_path):
    r = hcv(["dt-crit", "hertz", "--timeout", "5"], cwd=tmp_path)
    lines = r.stderr.strip().splitlines()
    words = "--timeout '5' bounds the runs of a code: it needs --adapter CODE"
    assert_true(r.returncode == 2 and len(lines) == 1 and words in lines[0] and not r.stdout,
                got=f"exit {r.returncode}, stderr {r.stderr[-300:]!r}",
                should=f"exit 2 and one line with {words!r}", claim=CLAIM,
                call="hcv dt-crit hertz --timeout 5")  # fmt: skip


def test_dt_crit_timeout_default_is_the_bench_run_timeout(capsys):
    """One default for a code's run: hcv dt-crit --adapter's is hcv bench's [run] timeout,
    and ``hcv dt-crit --help`` states it."""
    bench = default_tolerances()["run"]["timeout"]
    with pytest.raises(SystemExit):
        _parser(("dt-crit",)).parse_args(["dt-crit", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert_true(RUN_TIMEOUT_S == bench and f"(default {RUN_TIMEOUT_S:g}," in text,
                got=f"RUN_TIMEOUT_S {RUN_TIMEOUT_S}, bench {bench}, help {text[-300:]!r}",
                should="equal, and the help saying the default", claim=CLAIM,
                call="hcv dt-crit --help")  # fmt: skip


def test_codes_table_gives_a_crashing_code_its_row():
    """`assembly_codes_table` (the report's codes table) runs an isolated code in a bench
    worker process too: the code's crash is its row's note, the suite's own numbers stay."""
    spec = "verification._assembly_codes:SegfaultingChainCode"
    rows = assembly_codes_table(codes=(spec,), sizes=(2,), horizon=200)
    words = f"{spec} failed: crashed (killed by signal 11, SIGSEGV)"
    assert_true(len(rows) == 1 and words in rows[0].note and math.isnan(rows[0].dt_crit)
                and rows[0].dt_crit_suite > 0,
                got=repr(rows), should=f"one row noting {words!r}, the suite's dt_crit",
                claim=CLAIM, call=f"assembly_codes_table(codes=({spec!r},))")  # fmt: skip


# -- the codes ----------------------------------------------------------------------------


def _positions_match(adapter, half_step_v: bool):
    for n, walls in ((2, "both"), (3, "one")):
        req = _request(n, DT_FRACTION * _dt_safe(2), STEPS, walls)
        assert_run_is_verlet(adapter, req, verlet_chain, half_step_v=half_step_v, x_tol=X_TOL,
                             v_tol=V_TOL, what=f"chain n={n} walls={walls}")  # fmt: skip


def _dt_crit_in_suite_ensemble(adapter):
    assert_dt_crit_in_suite_ensemble(adapter, chain_scene(2), horizon=2000)


liggghts = code_fixture("liggghts")
lammps = code_fixture("lammps")
yade = code_fixture("yade")


@needs("liggghts")
def test_liggghts_chain_is_velocity_verlet_of_the_scene(liggghts):
    _positions_match(liggghts, half_step_v=False)


@needs("yade")
def test_yade_chain_is_leapfrog_of_the_scene(yade):
    # leapfrog: the positions of velocity Verlet, the velocity of the half step
    _positions_match(yade, half_step_v=True)


@needs("liggghts")
def test_liggghts_dt_crit_lies_in_the_suites_ensemble(liggghts):
    _dt_crit_in_suite_ensemble(liggghts)


@needs("yade")
def test_yade_dt_crit_lies_in_the_suites_ensemble(yade):
    _dt_crit_in_suite_ensemble(yade)


@needs("lammps")
def test_lammps_chain_is_velocity_verlet_of_the_scene(lammps):
    _positions_match(lammps, half_step_v=False)


@needs("lammps")
def test_lammps_dt_crit_lies_in_the_suites_ensemble_and_it_gives_no_advice(lammps):
    _dt_crit_in_suite_ensemble(lammps)
    advice = lammps.step_advice(_request(2, 1e-8, 10))
    assert_true(advice == {}, got=repr(advice), should="{} (LAMMPS computes no step advice)",
                claim=CLAIM, call="LammpsAdapter.step_advice")  # fmt: skip


def _advice_is_the_codes_whatever_the_step(adapter, names, material):
    """The advice is a property of the chain, not of the step it is asked at: LIGGGHTS'
    times are dt over the fractions it prints, YADE's PWaveTimeStep reads the material."""
    assert_advice_is_the_codes(adapter, lambda dt: _request(2, dt, 200), _dt_safe(2), names,
                               material, what="chain")  # fmt: skip


@needs("liggghts")
def test_liggghts_advice_is_its_rayleigh_and_hertz_times(liggghts):
    _advice_is_the_codes_whatever_the_step(liggghts, ("rayleigh", "hertz"), "rayleigh")


@needs("yade")
def test_yade_advice_is_pwave_and_global_stiffness(yade):
    _advice_is_the_codes_whatever_the_step(
        yade, ("PWaveTimeStep", "GlobalStiffnessTimeStepper"), "PWaveTimeStep"
    )


def test_docs_block_is_the_generators_table():
    """docs/assemblies.md types the codes' table only inside its generated block, in the
    generator's columns (`python -m reference_impl.campaign.assembly_codes_doc` rewrites it)."""
    from pathlib import Path

    from reference_impl.bench.assembly_codes import CODES
    from reference_impl.campaign.assembly_codes_doc import END, HEADER, START

    page = (Path(__file__).resolve().parent.parent / "docs" / "assemblies.md").read_text()
    assert_true(START in page and END in page, got="no generated block",
                should=f"{START} ... {END}", claim=CLAIM, call="docs/assemblies.md")  # fmt: skip
    block = page.split(START, 1)[1].split(END, 1)[0].strip().splitlines()
    assert_true(block and block[0] == HEADER, got=repr(block[:1]), should=repr(HEADER),
                claim=CLAIM, call="docs/assemblies.md block header")  # fmt: skip
    codes = {ln.split("|")[1].strip() for ln in block[2:] if ln.startswith("| ")}
    assert_true(codes == set(CODES), got=repr(sorted(codes)), should=repr(sorted(CODES)),
                claim=CLAIM, call="docs/assemblies.md block rows")  # fmt: skip
