"""``hcv sweep`` of ``bench:ADAPTER`` tasks: what belongs to the code.

Adapter options (``adapter.*``), the step (``run.steps_per_contact``) and calibration
keys go to the case's code settings, never into the scene; a bench case gives rows with
the measured columns; scorecards that fail make the sweep fail (issue 17).
"""

from __future__ import annotations

import textwrap

import pytest

from reference_impl.sweep import SweepSpecError, parse_spec, run_case
from verification._sweeps import cli, needs_dask
from verification.assertions import assert_true

_BENCH_SPEC = textwrap.dedent(
    """
    task = "bench:reference"
    [scene]
    name = "lin"
    mass = 0.01
    velocities = [1.0]
    kind = "impact"
    [scene.potential]
    family = "power"
    k = 1.0e4
    p = 1.0
    [scene.damping]
    law = "universal"
    zeta = 0.1
    [sweep]
    "run.steps_per_contact" = [10, 40, 160]
    """
)


def test_code_keys_are_kept_apart_from_the_scene():
    """run.* / adapter.* keys go to the case's code settings, never into the scene."""
    spec = parse_spec(
        _BENCH_SPEC.replace("bench:reference", "bench:lammps[damping=velocity]").replace(
            "[sweep]", '[sweep]\n"adapter.eta_n0" = [1.0, 2.0]'
        )
    )  # the adapter's module is imported to check the option name; LAMMPS is not loaded
    assert len(spec.cases) == 6 and not spec.invalid
    c = spec.cases[1]
    assert c.code == {"adapter": {"eta_n0": 1.0}, "run": {"steps_per_contact": 40}}
    assert "run" not in c.scene and "adapter" not in c.scene
    assert c.params == {"adapter.eta_n0": 1.0, "run.steps_per_contact": 40}
    assert len({x.key for x in spec.cases}) == 6  # the code settings are part of the key
    assert c.payload()["code"] == c.code


@pytest.mark.parametrize(
    ("edit", "needle"),
    [
        (lambda s: s.replace('task = "bench:reference"', 'task = "solve"'), "bench:ADAPTER"),
        (lambda s: s.replace("run.steps_per_contact", "run.steps"), "run.steps"),
        (lambda s: s.replace("[sweep]", '[sweep]\n"calibrate.target" = [0.5]'), "calibrate"),
        (
            lambda s: s.replace('task = "bench:reference"', 'task = "calibrate:reference"'),
            "[calibrate]",
        ),
        (lambda s: s + "[calibrate]\nparam = 'x'\n", "calibrate"),
    ],
)
def test_bad_code_keys_are_refused_with_one_line(edit, needle):
    with pytest.raises(SweepSpecError) as info:
        parse_spec(edit(_BENCH_SPEC), "bad.toml")
    msg = str(info.value)
    assert needle in msg and "\n" not in msg, msg


def test_unknown_adapter_option_is_an_invalid_case():
    spec = parse_spec(_BENCH_SPEC.replace('task = "bench:reference"', 'task = "bench:cmd:true"')
                      .replace("[sweep]", '[sweep]\n"adapter.timeout" = [5, 10]'))  # fmt: skip
    assert not spec.invalid
    with pytest.raises(SweepSpecError) as info:  # every case invalid: the spec is refused
        parse_spec(_BENCH_SPEC.replace("[sweep]", '[sweep]\n"adapter.nosuch" = [1]'))
    assert "nosuch" in str(info.value)


def test_bad_steps_per_contact_refuses_the_spec():
    """A step hcv bench refuses refuses the sweep (issue 29), not one failed row each."""
    with pytest.raises(SweepSpecError) as info:
        parse_spec(_BENCH_SPEC.replace("[10, 40, 160]", "[40, 1, 2.5]"))
    msg = str(info.value)
    assert "run.steps_per_contact = 1" in msg and "got 1" in msg and "\n" not in msg, msg


def test_bench_task_sweeps_the_step_and_keeps_measured_columns():
    """run.steps_per_contact sets dt = t_c / N; rows carry both restitutions and errors.

    The reference velocity Verlet's restitution error falls with N (its order is at
    least 1 with the half-step dashpot, README tolerances note), so the swept step
    must show a falling error, and dt must be the exact contact time over N.
    """
    spec = parse_spec(_BENCH_SPEC)
    rows = [run_case(c.payload())[0] for c in spec.cases]
    ns = [c.code["run"]["steps_per_contact"] for c in spec.cases]
    t_c = rows[0]["exact.contact_time"]
    for n, r in zip(ns, rows, strict=True):
        assert abs(r["dt"] * n - t_c) <= 1e-12 * t_c, (n, r["dt"], t_c)
        for col in ("measured.restitution", "measured.restitution_zero_force",
                    "measured.contact_time", "measured.max_penetration",
                    "rel_error.restitution", "rel_error.contact_time",
                    "rel_error.restitution_asked"):  # fmt: skip
            assert isinstance(r.get(col), float), (col, r.get(col))
    errs = [r["rel_error.restitution"] for r in rows]
    assert_true(
        errs[0] > errs[1] > errs[2],
        got=str(errs),
        should="falling with steps per contact 10, 40, 160",
        claim="sweep",
        call="run_case bench:reference with run.steps_per_contact",
    )


def test_spec_with_options_composes_adapter_specs():
    from reference_impl.adapters.registry import parse_spec as parse_adapter
    from reference_impl.bench.calibration.calibrate import spec_with_options

    s = spec_with_options("mujoco[solref=direct]", {"dampratio": 0.25, "integrator": "RK4"})
    assert parse_adapter(s) == ("mujoco", {"solref": "direct", "dampratio": 0.25,
                                           "integrator": "RK4"})  # fmt: skip
    s = spec_with_options("cmd[timeout=5]:python x.py", {"label": "a"})
    assert parse_adapter(s) == ("subprocess", {"command": "python x.py", "timeout": 5,
                                               "label": "a"})  # fmt: skip
    assert spec_with_options("lammps", {}) == "lammps"
    with pytest.raises(SweepSpecError.__mro__[1]):  # HCVInputError
        spec_with_options("lammps", {"damping": "a,b"})


@needs_dask
def test_a_bench_sweep_whose_metrics_fail_says_so_and_exits_1(tmp_path, capsys):
    """Runs that all break (a flipped sign) are cases that ran but failed their
    scorecard: not "2 cases ok" and exit 0 (issue 17)."""
    spec = tmp_path / "bench.toml"
    spec.write_text(
        textwrap.dedent(
            """
            task = "bench:verification._wrong_codes:FlippedSign"
            [scene]
            name = "s"
            mass = 0.01
            velocities = [1.0]
            kind = "impact"
            [scene.potential]
            family = "power"
            k = 1e6
            p = 1.0
            [sweep]
            "potential.p" = [1.0, 1.5]
            """
        ),
        encoding="utf-8",
    )
    out = tmp_path / "out"
    code, stdout, err = cli(["sweep", str(spec), "--workers", "1", "--out", str(out)], capsys)
    assert_true(
        code == 1 and "2 of 2 benchmarked cases did not pass" in stdout,
        got=f"exit {code}: {stdout}{err}",
        should="exit 1, both scorecards failed",
        claim="sweep",
        call="hcv sweep bench:FlippedSign",
    )
    summary = (out / "summary.md").read_text()
    assert_true(
        "scorecards: 0 of 2 (case, variant) passed; 2 fail" in summary,
        got=summary[:600],
        should="the summary counts the failed scorecards",
        claim="sweep",
        call="summary.md",
    )
