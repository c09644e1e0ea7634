"""``hcv sweep`` refuses what the single commands refuse, before any cluster (issue 29),
and a local cluster prints nothing about a busy dashboard port (issue 26, item 7).
"""

from __future__ import annotations

import socket
import textwrap
import warnings

import pytest

from reference_impl.adapters.mujoco import mujoco_available
from reference_impl.sweep import _runner
from reference_impl.sweep._runner import run_cases
from verification._sweeps import cli, needs_dask
from verification.assertions import assert_true

CLAIM = "sweep"  # the sweep machinery, not a paper claim

_SCENE = textwrap.dedent(
    """
    [scene]
    name = "lin"
    mass = 4.1103e-3
    velocities = [1.0]
    kind = "impact"
    [scene.potential]
    family = "power"
    k = 1.0e6
    p = 1.0
    [scene.damping]
    law = "universal"
    restitution = 0.5
    """
)
# A calibration of the one-knob test code (no external code needed) and a bench of MuJoCo.
_CALIBRATE = (
    'task = "calibrate:verification._calibrate_codes:LinearDashpot"\n'
    "[calibrate]\n{calibrate}\n" + _SCENE + "[sweep]\n{sweep}\n"
)
_BENCH = 'task = "bench:{adapter}"\n' + _SCENE + "[sweep]\n{sweep}\n"
_MUJOCO = "mujoco[solref=direct,impedance=constant,integrator=Euler]"
_GOOD_CAL = 'param = "gain"\ntarget = 0.5\nrange = [0.0, 10.0]'

# (spec text, what the one line must name): the 14 kinds of issue 29, each next to a
# good value so that the spec would otherwise run.
_BAD = [
    (_CALIBRATE.format(calibrate=_GOOD_CAL, sweep='"run.steps_per_contact" = [10, 0]'), "got 0"),
    (_CALIBRATE.format(calibrate=_GOOD_CAL, sweep='"run.steps_per_contact" = [10, 1]'), "got 1"),
    (
        _CALIBRATE.format(calibrate=_GOOD_CAL, sweep='"run.steps_per_contact" = [10, 2.5]'),
        "got 2.5",
    ),
    (
        _CALIBRATE.format(calibrate=_GOOD_CAL, sweep='"run.steps_per_contact" = [10, "20"]'),
        "got '20'",
    ),
    (
        _CALIBRATE.format(calibrate=_GOOD_CAL, sweep='"run.steps_per_contact" = [10, 1e9]'),
        "got 1000000000.0",
    ),
    (_BENCH.format(adapter="reference", sweep='"run.steps_per_contact" = [10, 0]'), "got 0"),
    (_BENCH.format(adapter="reference", sweep='"run.steps_per_contact" = [10, "20"]'), "got '20'"),
    (_CALIBRATE.format(calibrate=_GOOD_CAL, sweep='"calibrate.target" = [0.5, 0]'), "got 0"),
    (_CALIBRATE.format(calibrate=_GOOD_CAL, sweep='"calibrate.target" = [0.5, 1.5]'), "got 1.5"),
    (_CALIBRATE.format(calibrate=_GOOD_CAL, sweep='"calibrate.target" = [0.5, nan]'), "got nan"),
    (
        _CALIBRATE.format(calibrate=_GOOD_CAL, sweep='"calibrate.end" = ["overlap", "middle"]'),
        "'middle'",
    ),
    (
        _CALIBRATE.format(
            calibrate=_GOOD_CAL, sweep='"calibrate.range" = [[0.0, 10.0], [10.0, 0.0]]'
        ),
        "[10.0, 0.0]",
    ),
    (
        _CALIBRATE.format(
            calibrate=_GOOD_CAL + "\nv0 = -1", sweep='"run.steps_per_contact" = [10]'
        ),
        "got -1",
    ),
    (_CALIBRATE.format(calibrate=_GOOD_CAL, sweep='"calibrate.v0" = [1.0, -1.0]'), "got -1.0"),
    (
        _CALIBRATE.format(
            calibrate=_GOOD_CAL.replace("0.5", "1.5"), sweep='"run.steps_per_contact" = [10]'
        ),
        "got 1.5",
    ),
]
_BAD_MUJOCO = [
    (_BENCH.format(adapter=_MUJOCO, sweep='"adapter.dampratio" = [0.2, nan]'), "got nan"),
    (_BENCH.format(adapter=_MUJOCO, sweep='"adapter.dampratio" = [0.2, inf]'), "got inf"),
    (_BENCH.format(adapter=_MUJOCO, sweep='"adapter.dampratio" = [0.2, -0.5]'), "got -0.5"),
    (_BENCH.format(adapter=_MUJOCO, sweep='"adapter.integrator" = ["Euler", "Eulr"]'), "'Eulr'"),
]


@needs_dask
def test_a_busy_port_8787_gives_no_warning():
    """Distributed starts an HTTP server even without a dashboard, on 8787 by default,
    and warned "Port 8787 is already in use" when another cluster held it."""
    holder = socket.socket()
    holder.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        try:
            holder.bind(("", 8787))
            holder.listen()
        except OSError:
            pass  # held by another process: busy either way
        with warnings.catch_warnings(record=True) as got:
            warnings.simplefilter("always")
            values = run_cases([1, -2], abs, workers=1)
    finally:
        holder.close()
    port = [str(w.message) for w in got if "already in use" in str(w.message)]
    assert_true(
        values == [1, 2] and not port,
        got=f"values {values}, warnings {port}",
        should="[1, 2] and no port warning",
        claim=CLAIM,
        call="run_cases(workers=1) with port 8787 busy",
    )


def _refused(tmp_path, monkeypatch, capsys, text: str, needle: str) -> None:
    """hcv sweep of ``text``: exit 2, one stderr line naming ``needle``, no Dask, no DIR."""
    started = []
    monkeypatch.setattr(_runner, "open_client", lambda *a, **k: started.append("cluster"))
    monkeypatch.setattr(_runner, "dask_available", lambda: started.append("dask") or True)
    spec = tmp_path / "bad.toml"
    spec.write_text(text, encoding="utf-8")
    out = tmp_path / "out"
    code, stdout, err = cli(["sweep", str(spec), "--workers", "1", "--out", str(out)], capsys)
    lines = err.strip().splitlines()
    assert_true(
        code == 2 and len(lines) == 1 and needle in lines[0] and not started
        and not out.exists() and not stdout,
        got=f"exit {code}, stderr {lines}, Dask touched {started}, DIR made {out.exists()}",
        should=f"exit 2, one line naming {needle!r}, Dask never touched, nothing written",
        claim=CLAIM,
        call=f"hcv sweep {text.splitlines()[0]} ... {text.strip().splitlines()[-1]}",
    )  # fmt: skip


@pytest.mark.parametrize(("text", "needle"), _BAD)
def test_a_bad_code_setting_refuses_the_spec(tmp_path, monkeypatch, capsys, text, needle):
    _refused(tmp_path, monkeypatch, capsys, text, needle)


@pytest.mark.mujoco
@pytest.mark.skipif(mujoco_available() is not None, reason=str(mujoco_available()))
@pytest.mark.parametrize(("text", "needle"), _BAD_MUJOCO)
def test_a_bad_adapter_option_refuses_the_spec(tmp_path, monkeypatch, capsys, text, needle):
    _refused(tmp_path, monkeypatch, capsys, text, needle)


def test_sweeping_the_calibrated_option_refuses_the_spec(tmp_path, monkeypatch, capsys):
    text = _CALIBRATE.format(calibrate=_GOOD_CAL, sweep='"adapter.gain" = [0.1, 0.2]')
    _refused(tmp_path, monkeypatch, capsys, text, "adapter.gain is the option being calibrated")


def test_a_refused_spec_never_imports_dask(tmp_path):
    """In a fresh process: the refusal comes before Dask is imported at all."""
    import os
    import subprocess
    import sys

    from verification._hcv_run import ROOT

    spec = tmp_path / "bad.toml"
    spec.write_text(
        _CALIBRATE.format(calibrate=_GOOD_CAL, sweep='"run.steps_per_contact" = [10, 0]'),
        encoding="utf-8",
    )
    code = (
        "import sys; from reference_impl.cli import main; "
        f"rc = main(['sweep', {str(spec)!r}, '--out', {str(tmp_path / 'out')!r}]); "
        "print(rc, sorted(m for m in ('dask', 'distributed') if m in sys.modules))"
    )
    proc = subprocess.run(
        [sys.executable, "-c", code],
        cwd=ROOT,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert_true(
        proc.stdout.strip() == "2 []" and "got 0" in proc.stderr,
        got=f"{proc.stdout.strip()!r}, stderr {proc.stderr.strip()[-300:]!r}",
        should="'2 []': exit 2, neither dask nor distributed imported",
        claim=CLAIM,
        call="hcv sweep (run.steps_per_contact = 0) in a new process",
    )
