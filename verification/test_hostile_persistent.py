"""A protocol that trusts no line (issue 36 item 5): ``cmd:`` programs that answer ahead,
echo a wrong kind of id, or step with another dt than the one asked.

Each program is written into ``tmp_path``; it integrates with `_persistent_script`'s
`integrate` (velocity Verlet of the universal law, no third-party import) and then
breaks one rule. Every breach fails its run in one line naming the field; a correct
program that accumulates t by additions of dt is still accepted.
"""

from __future__ import annotations

import sys
import textwrap
from pathlib import Path

import pytest

from reference_impl import solve_impact
from reference_impl.adapters import AdapterScene, get_adapter
from reference_impl.adapters.base import AdapterOutputError
from reference_impl.bench.scorecard.runner import resolve_scenes

from .assertions import assert_true

HERE = Path(__file__).resolve().parent
CLAIM = "bench-persistent"  # the benchmark machinery, not a paper claim

_PROGRAM = textwrap.dedent(
    """
    import json, sys
    sys.path.insert(0, {here!r})
    from _persistent_script import integrate

    MODE = {mode!r}


    def answer(req):
        scene = req["scene"]
        out = integrate(scene)
        dt = scene["dt"]
        if MODE == "own-dt":  # steps with its own dt, whatever is asked
            out["t"] = [k * 1e-7 for k in range(len(out["t"]))]
        elif MODE == "accumulated":  # t += dt: round-off grows with the step count
            t, acc = [], 0.0
            for _ in out["t"]:
                t.append(acc)
                acc += dt
            out["t"] = t
        if "id" in req:
            out["id"] = {{"id-true": True, "id-float": float(req["id"])}}.get(MODE, req["id"])
        return out


    if {persistent!r}:
        for line in sys.stdin:
            req = json.loads(line)
            if MODE == "ahead":  # one request read, sixty answers written (guessed ids)
                lines = []
                for k in range(60):
                    out = answer(req)
                    out["id"] = req["id"] + k
                    lines.append(json.dumps(out) + "\\n")
                sys.stdout.write("".join(lines))
            else:
                sys.stdout.write(json.dumps(answer(req)) + "\\n")
            sys.stdout.flush()
    else:
        sys.stdout.write(json.dumps(answer(json.loads(sys.stdin.read()))))
    """
)


def _program(tmp_path: Path, mode: str, persistent: bool = True) -> str:
    path = tmp_path / f"code_{mode}.py"
    path.write_text(_PROGRAM.format(here=str(HERE), mode=mode, persistent=persistent))
    flag = "[persistent=true]" if persistent else ""
    return f"cmd{flag}:{sys.executable} {path}"


def _scene(v0: float, steps_per_contact: int = 50) -> AdapterScene:
    sc = resolve_scenes(["hertz-damped"])[0]
    t_c = solve_impact(sc.potential, sc.mass, v0, sc.zeta or 0.0).contact_time
    return AdapterScene.from_scene(sc, v0, t_c / steps_per_contact, 4 * steps_per_contact)


def _one_line_refusal(adapter, scene, needle: str, call: str) -> str:
    with pytest.raises(AdapterOutputError) as info:
        adapter.impact(scene)
    msg = str(info.value)
    assert_true(
        needle in msg and "\n" not in msg,
        got=repr(msg),
        should=f"one line containing {needle!r}",
        claim=CLAIM,
        call=call,
    )
    return msg


def test_answers_written_before_their_request_are_refused(tmp_path):
    """Once, one request read and 60 answers written served the whole bench."""
    adapter = get_adapter(_program(tmp_path, "ahead"))
    try:
        adapter.impact(_scene(0.1))  # the first answer follows its request: accepted
        with pytest.raises(AdapterOutputError) as info:
            adapter.impact(_scene(1.0))
        msg = str(info.value)
        assert_true(
            ("before request" in msg or "carries id" in msg) and "\n" not in msg,
            got=repr(msg),
            should="one line refusing the answer written ahead",
            claim=CLAIM,
            call="cmd[persistent=true] answering ahead",
        )
        adapter.impact(_scene(5.0))  # a fresh process: its first answer follows its request
        assert_true(
            adapter._server.starts == 2,
            got=f"{adapter._server.starts} starts",
            should="2 (the process replaced after the refusal)",
            claim=CLAIM,
            call="cmd[persistent=true] answering ahead",
        )
    finally:
        adapter.close()


@pytest.mark.parametrize("mode, kind", [("id-true", "bool"), ("id-float", "float")])
def test_an_id_that_is_not_an_integer_is_refused(tmp_path, mode, kind):
    """``"id": true`` answered request 1 (True == 1), ``"id": 7.0`` request 7."""
    adapter = get_adapter(_program(tmp_path, mode))
    try:
        _one_line_refusal(adapter, _scene(1.0), f"(a {kind}: 'id' must be", f"cmd {mode}")
        assert not adapter._server.alive  # replaced: its next answer could be out of step
    finally:
        adapter.close()


@pytest.mark.parametrize("persistent", [True, False], ids=["persistent", "one-shot"])
def test_a_code_stepping_with_its_own_dt_is_refused(tmp_path, persistent):
    """t was never compared with the asked dt: answers made for another step passed (a
    critical step of infinity)."""
    adapter = get_adapter(_program(tmp_path, "own-dt", persistent))
    try:
        msg = _one_line_refusal(adapter, _scene(1.0), "'t[1]' = 1e-07 s, should be 1 x dt",
                                "cmd own-dt")  # fmt: skip
        assert "the asked step dt" in msg
    finally:
        adapter.close()


def test_t_accumulated_by_additions_of_dt_is_accepted(tmp_path):
    """The round-off allowance: t += dt over 20 000 steps (a contact at 20 000 steps per
    contact; a sustained scene's budget) is within (i + 2) eps i dt of i dt; the check
    refuses steps, not round-off."""
    adapter = get_adapter(_program(tmp_path, "accumulated"))
    try:
        tr = adapter.impact(_scene(1.0, steps_per_contact=20000))
        assert tr.t.size > 20000
    finally:
        adapter.close()
