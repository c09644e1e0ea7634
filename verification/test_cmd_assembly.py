"""Assembly scenes from any language: ``cmd[assembly=...]:COMMAND`` (issue 39 §4, contract item 14).

The program is verification/_assembly_script.py, a DEM code of its own (numpy velocity
Verlet of chains and periodic lattices, nothing of the suite), in one-shot and persistent
mode. Its Delta t_crit by ``hcv dt-crit SCENE --adapter 'cmd[assembly=...]:...'`` is the
suite's kernel's on a chain (the same step, bit for bit of the search's grid) and lies in
the suite's ensemble on a lattice (the kernel holds each contact's normal fixed); its
positions are those of the independent Verlets of `_assembly_codes` in
both modes (the request carried the scene whole); its advice is judged as a built-in
code's. Hostile answers (wrong shapes, null or text where a number is, too few steps, a
step not dt, a decline on two lines, a crash, a hang, no id, answers written twice) and
bad declarations are one line each. On main a ``cmd:`` program declined every assembly
(``assembly=`` was an option of the code), so every test that runs one failed there.
"""

from __future__ import annotations

import json
import math
import sys
import time
import uuid
from pathlib import Path

import numpy as np
import pytest

from reference_impl.adapters._cmd_assembly import assembly_to_json
from reference_impl.adapters.base import (
    AdapterDeclined,
    AdapterOutputError,
    AdapterRunError,
    ChainRequest,
)
from reference_impl.adapters.registry import get_adapter
from reference_impl.adapters.subprocess import _STDERR_TAIL
from reference_impl.assembly.model import assembly_model
from reference_impl.assembly.search import search_ensemble
from reference_impl.bench.assembly_codes import CODE_GRID, lattice_request, lattice_scene
from reference_impl.errors import HCVInputError
from reference_impl.potentials.power import PowerLaw
from reference_impl.scenes import scene_toml
from reference_impl.stability.criteria import EnergyGrowth
from verification._assembly_codes import verlet_chain, verlet_lattice
from verification._hcv_run import hcv, processes_with

from .assertions import assert_close, assert_true

CLAIM = "cmd-assembly"  # the cmd: form of contract item 14 (issue 39 §4), not a paper claim
_SCRIPT = Path(__file__).with_name("_assembly_script.py")
_PROGRAM = f"{sys.executable} {_SCRIPT}"
_SERVER = f"{_PROGRAM} --persistent"
K, M, R = 1.0879e10, 4.1103e-3, 5e-3  # chain-hertz: N/m^1.5, kg, m
# 500 steps: a search is ~28 runs within seconds in persistent mode (the suite's own
# search runs the same horizon, rule and grid).
HORIZON = 500
# Positions of the program against the independent Verlets: the JSON carries every float
# written in full (repr) and read back exactly, and both integrate the same formulas, so
# they agree to round-off; 1e-12 m (of x ~ 1e-2 m) allows another order of summation over
# 300 steps, while a wall or mass misread moves them by > 1e-7 m.
X_TOL = 1e-12
STEPS = 300


def _chain(n: int, walls: str, dt: float = 1e-7, steps: int = STEPS, **kw) -> ChainRequest:
    v = (1.0,) + (0.0,) * (n - 1)
    return ChainRequest("t", PowerLaw(K, 1.5), (M,) * n, R, walls, v, dt, steps, **kw)


def _square_toml(tmp_path) -> Path:
    """The catalogue's triangular lattice scene written as a 4 x 4 square (a file for hcv)."""
    text = scene_toml("lattice-hertz-triangular")
    for old, new in (('"triangular"', '"square"'), ("cells = 6", "cells = 4")):
        assert old in text, f"got no {old!r} in the scene, should be one [{CLAIM}, scene_toml]"
        text = text.replace(old, new)
    path = tmp_path / "square.toml"
    path.write_text(text)
    return path


def _one_line(r, status: int, words: str, call: str) -> None:
    lines = r.stderr.strip().splitlines()
    assert_true(r.returncode == status and len(lines) == 1 and words in lines[0] and not r.stdout,
                got=f"exit {r.returncode}, stderr {r.stderr[-400:]!r}, stdout {r.stdout[:80]!r}",
                should=f"exit {status} and one line with {words!r}", claim=CLAIM, call=call)  # fmt: skip


# -- Delta t_crit and the advice through hcv ------------------------------------------------


def test_chain_dt_crit_is_the_suites_kernels_and_its_advice_is_judged(tmp_path):
    spec = f"cmd[assembly=chain,advice=true,persistent=true]:{_SERVER}"
    r = hcv(["dt-crit", "chain-hertz", "--adapter", spec, "--json", "--horizons", str(HORIZON)],
            cwd=tmp_path)  # fmt: skip
    assert_true(r.returncode == 0, got=f"exit {r.returncode}: {r.stderr[-300:]!r}",
                should="exit 0", claim=CLAIM, call=f"hcv dt-crit chain-hertz --adapter {spec}")  # fmt: skip
    rep = json.loads(r.stdout)["code"]
    # The same Verlet of the same chain on the same grid: the same smallest failing step.
    assert_true(rep["dt_crit"] == rep["dt_crit_suite"] and rep["evidence"] == "confirmed"
                and rep["n_bodies"] == 10 and math.isfinite(rep["dt_crit"]),
                got=repr({k: rep[k] for k in ("dt_crit", "dt_crit_suite", "evidence", "n_bodies")}),
                should="dt_crit equal to the suite's, confirmed, 10 bodies", claim=CLAIM,
                call="hcv dt-crit chain-hertz --adapter cmd[assembly=chain]")  # fmt: skip
    (advice,) = rep["advice"]
    # the program's own number (R / (4 v0) = 1.25e-3 s) arrives unchanged and is judged
    # as a built-in code's advice: safe when <= dt_crit, factor dt_crit / advice
    assert_true(advice["name"] == "quarter-crossing" and advice["dt"] == 0.25 * R / 1.0
                and advice["safe"] is (advice["dt"] <= rep["dt_crit"]) and not advice["safe"],
                got=repr(advice), should="quarter-crossing 0.00125 s, NOT safe", claim=CLAIM,
                call="hcv dt-crit --adapter cmd[advice=true] advice")  # fmt: skip
    assert_close(advice["factor"], rep["dt_crit"] / advice["dt"], rtol=1e-15, claim=CLAIM,
                 call="hcv dt-crit --adapter cmd[advice=true] factor")  # fmt: skip


def test_lattice_dt_crit_lies_in_the_suites_ensemble(tmp_path):
    spec = f"cmd[assembly=chain+lattice,persistent=true]:{_SERVER}"
    r = hcv(["dt-crit", str(_square_toml(tmp_path)), "--adapter", spec, "--json",
             "--horizons", str(HORIZON)], cwd=tmp_path)  # fmt: skip
    assert_true(r.returncode == 0, got=f"exit {r.returncode}: {r.stderr[-300:]!r}",
                should="exit 0", claim=CLAIM, call=f"hcv dt-crit square --adapter {spec}")  # fmt: skip
    rep = json.loads(r.stdout)["code"]
    sc = lattice_scene("square", 4)
    crit = EnergyGrowth(n_steps=HORIZON)
    ens = search_ensemble(assembly_model(sc), rep["dt_safe"], n_lanes=16, criterion=crit,
                          grid=CODE_GRID)  # fmt: skip
    # Contacts open and close: round-off (and the kernel's fixed normals, against the
    # program's actual lines of centres) move the smallest failing step within the
    # ensemble's spread; two grid resolutions (0.02 Delta t_safe) more on either side for
    # the k-section's bracket of each, as for the built-in codes.
    slack = 2 * CODE_GRID.resolution * rep["dt_safe"]
    lo, hi = float(ens.dt_crit.min()) - slack, float(ens.dt_crit.max()) + slack
    assert_true(lo <= rep["dt_crit"] <= hi and rep["n_bodies"] == 16 and rep["advice"] == []
                and rep["evidence"] in ("confirmed", "domain"),
                got=f"dt_crit {rep['dt_crit']:.6g} s ({rep['evidence']}), advice {rep['advice']}",
                should=f"in [{lo:.6g}, {hi:.6g}] s, no advice (none declared)", claim=CLAIM,
                call="hcv dt-crit square --adapter cmd[assembly=chain+lattice]")  # fmt: skip


# -- the request reaches the program whole, in both modes -----------------------------------


@pytest.mark.parametrize("persistent", [False, True], ids=["one-shot", "persistent"])
def test_runs_are_the_independent_verlets_in_both_modes(persistent):
    prog = _SERVER if persistent else _PROGRAM
    a = get_adapter(f"cmd[assembly=chain+lattice,advice=true,persistent={persistent}]:{prog}")
    try:
        for n, walls in ((3, "both"), (2, "one"), (2, "none")):
            req = _chain(n, walls)
            run = a.assembly(req)
            x, v, _ = verlet_chain(req)
            err = float(np.max(np.abs(run.x - x)))
            assert_true(run.x.shape == x.shape and err <= X_TOL, got=f"{run.x.shape}, max {err:.3g} m",
                        should=f"{x.shape}, <= {X_TOL:g} m", claim=CLAIM,
                        call=f"cmd chain n={n} walls={walls} persistent={persistent}")  # fmt: skip
            assert_close(run.v, v, rtol=0, atol=1e-9, claim=CLAIM,  # 1e-9 m/s of ~1 m/s: as x
                         call=f"cmd chain n={n} walls={walls} velocities")  # fmt: skip
        sc = lattice_scene("square", 4)
        req = lattice_request(sc, 2e-7, STEPS)
        run = a.assembly(req)
        x, _, _ = verlet_lattice(req)
        err = float(np.max(np.abs(run.x - x)))
        assert_true(err <= X_TOL, got=f"max {err:.3g} m", should=f"<= {X_TOL:g} m", claim=CLAIM,
                    call=f"cmd lattice square-4 persistent={persistent}")  # fmt: skip
        advice = a.step_advice(_chain(2, "both"))
        assert_true(advice == {"quarter-crossing": 0.25 * R}, got=repr(advice),
                    should="{'quarter-crossing': 0.00125}", claim=CLAIM, call="cmd step_advice")  # fmt: skip
    finally:
        a.close()


def test_request_object_carries_the_scene():
    chain = assembly_to_json(_chain(3, "both"))
    want = {"kind": "chain", "positions": [R, 3 * R, 5 * R], "velocities": [1.0, 0.0, 0.0],
            "masses": [M] * 3, "radii": [R] * 3, "contacts": [[0, 1], [1, 2]],
            "walls": [{"x": 0.0, "side": "left"}, {"x": 6 * R, "side": "right"}],
            "potential": {"family": "power", "k": K, "p": 1.5}, "stop_energy": None,
            "n_steps": STEPS, "dt": 1e-7}  # fmt: skip
    got = {k: chain[k] for k in want}
    assert_true(got == want, got=repr(got), should=repr(want), claim=CLAIM,
                call="assembly_to_json(chain of 3, walls both)")  # fmt: skip
    req = lattice_request(lattice_scene("square", 4), 1e-7, 10, stop_energy=2.0)
    lat = assembly_to_json(req)
    json.dumps(lat, allow_nan=False)  # plain JSON: no NaN or Infinity token
    same = (np.array_equal(lat["contacts"], req.contacts) and np.array_equal(lat["shifts"], req.shifts)
            and np.array_equal(lat["positions"], req.positions) and lat["periodic"] == [True, True, False]
            and lat["walls"] == [] and lat["stop_energy"] == 2.0 and lat["kind"] == "lattice")  # fmt: skip
    assert_true(same, got=repr({k: lat[k] for k in ("kind", "periodic", "walls", "stop_energy")}),
                should="the request's contacts, shifts, positions; periodic x, y; no walls",
                claim=CLAIM, call="assembly_to_json(square lattice 4 x 4)")  # fmt: skip


def test_a_run_may_end_past_stop_energy():
    """Ended early past stop_energy is a run (the suite has decided by then); ended early
    below it is refused (`test_hostile_answers_are_one_line`, mode short)."""
    a = get_adapter(f"cmd[assembly=chain]:{_PROGRAM}")
    req = _chain(2, "both", stop_energy=0.4 * 0.5 * M)  # 40 % of the striker's energy
    run = a.assembly(req)
    assert_true(run.x.shape == (2, 2), got=repr(run.x.shape), should="(2, 2): the start and one step",
                claim=CLAIM, call="cmd chain stop_energy 0.4 E_0")  # fmt: skip


# -- hostile answers, declarations and processes --------------------------------------------


@pytest.mark.parametrize(
    ("mode", "error", "words"),
    [("shape", AdapterOutputError, "'x' must be an array of shape (samples, 3), got shape (301, 2)"),
     ("nan-start", AdapterOutputError, "'x[0]' is not the request's start: entry 0 = nan"),
     ("short", AdapterOutputError, "the run ended after 10 of 300 steps"),
     ("text", AdapterOutputError, "x[1, 0] = '0.005"),
     ("dt", AdapterOutputError, "'t[1]' = 1.00999"),
     ("error", AdapterRunError, "reported error: lost a body in the neighbour list"),
     ("crash", AdapterRunError, "command failed, exit status 3"),
     ("unsupported", AdapterDeclined, "this code runs no such scene second line")],
)  # fmt: skip
def test_hostile_answers_are_one_line(mode, error, words):
    a = get_adapter(f"cmd[assembly=chain]:{_PROGRAM} --mode {mode}")
    with pytest.raises(error) as exc:
        a.assembly(_chain(3, "both"))
    msg = str(exc.value)
    assert_true(type(exc.value) is error and words in msg and "\n" not in msg,
                got=f"{type(exc.value).__name__}: {msg[:300]!r}", should=f"one line with {words!r}",
                claim=CLAIM, call=f"cmd --mode {mode}")  # fmt: skip
    if mode == "crash":  # the stderr tail is kept, cut to its last characters
        tail = exc.value.stderr
        assert_true(tail.endswith("segmentation fault (simulated)") and len(tail) <= _STDERR_TAIL + 3,
                    got=f"{len(tail)} characters ending {tail[-60:]!r}",
                    should=f"<= {_STDERR_TAIL + 3} ending with the crash", claim=CLAIM,
                    call="cmd --mode crash stderr")  # fmt: skip


def test_bad_advice_is_one_line_and_undeclared_advice_is_never_asked():
    with pytest.raises(
        AdapterOutputError, match=r"'advice.quarter-crossing' = '-1.0' must be a finite"
    ):
        get_adapter(f"cmd[assembly=chain,advice=true]:{_PROGRAM} --mode bad-advice").step_advice(
            _chain(2, "both"))  # fmt: skip
    # a program that would hang: without advice=true nothing is sent, no advice is given
    t0 = time.monotonic()
    advice = get_adapter(f"cmd[assembly=chain,timeout=30]:{_PROGRAM} --mode hang").step_advice(
        _chain(2, "both"))  # fmt: skip
    assert_true(advice == {} and time.monotonic() - t0 < 5, got=repr(advice),
                should="{} at once (nothing sent)", claim=CLAIM, call="cmd step_advice undeclared")  # fmt: skip


def test_undeclared_kinds_are_declined_in_one_line_before_any_run():
    checks = [
        (f"cmd[timeout=5]:{_PROGRAM} --mode hang", _chain(2, "both"),
         "does not run assembly scenes"),
        (f"cmd[assembly=chain,timeout=5]:{_PROGRAM} --mode hang",
         lattice_request(lattice_scene("square", 4), 1e-7, 10), "does not run lattice scenes"),
        (f"cmd[assembly=lattice,timeout=5]:{_PROGRAM} --mode hang", _chain(2, "both"),
         "does not run chain scenes (declared assembly=lattice)"),
    ]  # fmt: skip
    for spec, req, words in checks:
        with pytest.raises(AdapterDeclined) as exc:
            get_adapter(spec).assembly(req)
        assert_true(words in exc.value.declined, got=repr(exc.value.declined),
                    should=f"one line with {words!r}", claim=CLAIM, call=spec[:40])  # fmt: skip


@pytest.mark.parametrize(
    ("args", "words"),
    [("assembly=chian", "assembly='chian' is not one of chain, lattice"),
     ("assembly=chain+chain", "assembly='chain+chain'"),
     ("assembly=true", "assembly=True"),
     ("advice=true", "advice=true needs assembly="),
     ("assembly=chain,advice=maybe", "advice must be true or false, got 'maybe'"),
     ("assembyl=chain", "'assembyl' looks like a misspelt 'assembly'")],
)  # fmt: skip
def test_bad_declarations_are_refused_in_one_line(args, words):
    with pytest.raises(HCVInputError) as exc:
        get_adapter(f"cmd[{args}]:{_PROGRAM}")
    msg = str(exc.value)
    assert_true(words in msg and "\n" not in msg, got=repr(msg), should=f"one line with {words!r}",
                claim=CLAIM, call=f"get_adapter(cmd[{args}])")  # fmt: skip


@pytest.mark.parametrize(
    ("spec", "status", "words"),
    [(f"cmd:{_PROGRAM}", 2, "does not run assembly scenes"),
     (f"cmd[assembly=chain]:{_PROGRAM} --mode short", 1, "the run ended after 10 of")],
)  # fmt: skip
def test_hcv_dt_crit_says_it_in_one_line(spec, status, words, tmp_path):
    """Undeclared: exit status 2; a code that fails: 1 (a bad declaration is the same
    HCVInputError, refused in `get_adapter`; a decline the same AdapterDeclined as a
    Python code's, `test_hostile_answers_are_one_line` and test_assembly_codes*.py)."""
    r = hcv(["dt-crit", "chain-hertz", "--adapter", spec, "--horizons", "50"], cwd=tmp_path)
    _one_line(r, status, words, f"hcv dt-crit chain-hertz --adapter {spec[:50]}")


@pytest.mark.parametrize("persistent", [False, True], ids=["one-shot", "persistent"])
def test_a_hanging_program_times_out_and_is_killed(persistent):
    tag = uuid.uuid4().hex  # names this test's processes among everyone's
    prog = f"{_SERVER if persistent else _PROGRAM} --mode hang --tag {tag}"
    a = get_adapter(f"cmd[assembly=chain,timeout=1,persistent={persistent}]:{prog}")
    t0 = time.monotonic()
    with pytest.raises(AdapterRunError) as exc:
        a.assembly(_chain(2, "both"))
    took = time.monotonic() - t0
    a.close()
    left = processes_with(prog)  # the command line as started: argv joined by spaces
    # timeout 1 s, plus one more for a persistent start-up; 10 s bounds a loaded machine
    assert_true(getattr(exc.value, "timed_out", False) and took < 10 and not left,
                got=f"{exc.value!s} after {took:.1f} s, left {left}",
                should="a timeout within 10 s, no process left", claim=CLAIM,
                call=f"cmd --mode hang persistent={persistent}")  # fmt: skip


@pytest.mark.parametrize("persistent", [False, True], ids=["one-shot", "persistent"])
def test_hcv_dt_crit_timeout_kills_a_sleeping_program_in_one_line(persistent, tmp_path):
    """``hcv dt-crit --adapter 'cmd:...' --timeout 1`` on a program that sleeps: its
    process is killed at 1 s (the spec set no timeout of its own, so --timeout is its
    limit) and hcv stops with one line, exit status 2, no process left. On main there was
    no --timeout (argparse's usage lines) and the program had 60 s."""
    tag = uuid.uuid4().hex  # names this test's processes among everyone's
    prog = f"{_SERVER if persistent else _PROGRAM} --mode hang --tag {tag}"
    spec = f"cmd[assembly=chain,persistent={persistent}]:{prog}"
    t0 = time.monotonic()
    r = hcv(["dt-crit", "chain-hertz", "--adapter", spec, "--timeout", "1", "--horizons", "50"],
            cwd=tmp_path)  # fmt: skip
    took = time.monotonic() - t0
    lines = r.stderr.strip().splitlines()
    left = processes_with(prog)
    words = "timed out after 1 s"
    # 1 s of timeout, one more for a persistent start-up, hcv's own start; 30 s bounds a
    # loaded machine while staying far below the program's former 60 s
    assert_true(r.returncode == 2 and len(lines) == 1 and words in lines[0] and not r.stdout
                and not left and took < 30,
                got=f"exit {r.returncode} after {took:.1f} s, stderr {r.stderr[-300:]!r}, "
                f"left {left}",
                should=f"exit 2, one line with {words!r}, no process left", claim=CLAIM,
                call=f"hcv dt-crit --adapter cmd --mode hang --timeout 1 persistent={persistent}")  # fmt: skip


@pytest.mark.parametrize("persistent", [False, True], ids=["one-shot", "persistent"])
def test_an_answer_of_empty_lists_is_refused_before_it_is_parsed(persistent):
    """An answer within its byte bound whose parsed form would cost ~20 times its text
    (100 000 empty lists in meta) is refused from its bytes, in one line; the persistent
    process is replaced, as for an answer over the bound."""
    prog = f"{_SERVER if persistent else _PROGRAM} --mode brackets"
    a = get_adapter(f"cmd[assembly=chain,persistent={persistent}]:{prog}")
    try:
        with pytest.raises(AdapterOutputError) as exc:
            a.assembly(_chain(3, "both"))
        msg = str(exc.value)
        assert_true("the answer holds 100" in msg and "'['" in msg and "\n" not in msg
                    and (not persistent or not a._server.alive),
                    got=repr(msg[:300]), should="one line counting the '[', the process replaced",
                    claim=CLAIM, call=f"cmd --mode brackets persistent={persistent}")  # fmt: skip
    finally:
        a.close()


@pytest.mark.parametrize(
    ("mode", "words"),
    [("no-id", "carries id None"), ("twice", "before request")],
)  # fmt: skip
def test_persistent_answers_without_id_or_twice_are_refused(mode, words):
    """The persistent channel's rules hold for assembly requests: an answer must carry its
    request's id, and one written ahead (twice) fails the next request; the process is
    replaced and the run after that succeeds."""
    a = get_adapter(f"cmd[assembly=chain,persistent=true]:{_SERVER} --mode {mode}")
    try:
        if mode == "twice":
            a.assembly(_chain(2, "both", steps=20))  # answered (and answered again, ahead)
        with pytest.raises(AdapterOutputError) as exc:
            a.assembly(_chain(2, "both", steps=20))
        assert_true(words in str(exc.value) and "\n" not in str(exc.value),
                    got=repr(str(exc.value)[:300]), should=f"one line with {words!r}",
                    claim=CLAIM, call=f"cmd persistent --mode {mode}")  # fmt: skip
        if mode == "twice":
            run = a.assembly(_chain(2, "both", steps=20))  # a fresh process answers
            assert_true(run.x.shape == (21, 2) and a._server.starts == 2,
                        got=f"{run.x.shape}, {a._server.starts} starts",
                        should="(21, 2) from a second process", claim=CLAIM,
                        call="cmd persistent --mode twice, the run after")  # fmt: skip
    finally:
        a.close()
