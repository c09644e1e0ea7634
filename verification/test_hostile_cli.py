"""Random hostile scenes and expressions thrown at ``hcv solve`` and ``hcv dt-crit`` (issue 12).

Scene TOML text and potential expressions are drawn from a grammar (valid
shapes, nonsense values, unknown keys, raw text); nothing is derived from the
code under test. The only expectation is the CLI's contract: exit 0 with finite
numbers, or exit 2 with exactly one line on stderr, never anything else (no
traceback, no NaN printed as a result, no other status).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from reference_impl.cli import main

_FUNCS = ("exp", "log", "sqrt", "sin", "cos", "tanh", "atan", "asinh", "cosh", "abs", "nope")
_NUMBERS = st.sampled_from(
    ["0", "1", "2", "0.5", "1.5", "3", "1e-3", "1e3", "1e300", "-1", "1e-300", "2.5"]
)
_BAD_NUMBERS = st.sampled_from(
    [
        "nan",
        "inf",
        "-inf",
        "0",
        "-1.0",
        "1" + "0" * 400,
        "1e308",
        "true",
        '"1.0"',
        "[1.0]",
        "1e-320",
    ]
)


def _expressions(depth: int = 3) -> st.SearchStrategy[str]:
    """Expressions in q from a small grammar (numbers, q, + - * / **, functions, unary -)."""
    leaf = st.one_of(st.just("q"), _NUMBERS, st.just("k"))
    return st.recursive(
        leaf,
        lambda inner: st.one_of(
            st.tuples(inner, st.sampled_from(["+", "-", "*", "/", "**"]), inner).map(
                lambda t: f"({t[0]} {t[1]} {t[2]})"
            ),
            st.tuples(st.sampled_from(_FUNCS), inner).map(lambda t: f"{t[0]}({t[1]})"),
            inner.map(lambda e: f"-{e}"),
        ),
        max_leaves=2**depth,
    )


_GOOD_VALUE = st.floats(1e-2, 1e2).map(lambda x: repr(round(x, 4) or 1.0))


@st.composite
def _value(draw, bad_one_in: int = 12) -> str:
    """Mostly a plausible positive number, one time in ``bad_one_in`` a hostile one."""
    if draw(st.integers(1, bad_one_in)) == 1:
        return draw(st.one_of(_BAD_NUMBERS, _NUMBERS))
    return draw(_GOOD_VALUE)


_VALUE = _value()
# Pieces that vanish at q = 0 and rise (the paper's assumptions), to build laws that pass
# validation often enough for the solver to be exercised, not only the validator.
_MONOTONE = st.sampled_from(
    [
        "q**2",
        "q**2.5",
        "q**1.5",
        "q**3",
        "exp(q) - 1",
        "cosh(q) - 1",
        "sinh(q)**2",
        "q**2*(1 + q)",
        "log(1 + q**2)",
        "q**2/(1 + q)",
        "tanh(q)**2",
        "exp(q**2) - 1",
        "atan(q)**2",
        "abs(q)**2.5",
        "sqrt(q)**5",
        "q**4 + q**2",
    ]
)


@st.composite
def _monotone(draw) -> str:
    pieces = draw(st.lists(st.tuples(_GOOD_VALUE, _MONOTONE), min_size=1, max_size=3))
    return " + ".join(f"{c}*({e})" for c, e in pieces)


@st.composite
def _potential(draw) -> str:
    family = draw(
        st.sampled_from(
            [
                "power",
                "power",
                "expression",
                "expression",
                "expression",
                "sphere",
                "ellipsoid",
                "sum",
                "sum",
                "banana",
            ]
        )
    )
    lines = [f'family = "{family}"']
    if family == "power":
        lines += [f"k = {draw(_VALUE)}", f"p = {draw(_VALUE)}"]
    elif family == "expression":
        lines.append(f'U = "{draw(st.one_of(_monotone(), _monotone(), _expressions()))}"')
        if draw(st.booleans()):
            lines.append(f"params = {{ k = {draw(_VALUE)} }}")
    elif family == "sphere":
        lines += [f"R = {draw(_VALUE)}", f"Kn = {draw(_VALUE)}"]
    elif family == "ellipsoid":
        lines += [f"{key} = {draw(_VALUE)}" for key in ("a", "b", "c", "Kn")]
    elif family == "sum":
        lines.append(
            f'terms = [{{ family = "power", k = {draw(_VALUE)}, p = {draw(_VALUE)} }}, '
            f'{{ family = "expression", U = "{draw(_monotone())}" }}]'
        )
    if draw(st.integers(0, 9)) == 0:
        lines.append(f"{draw(st.sampled_from(['kk', 'alpha', 'U', 'p']))} = {draw(_VALUE)}")
    return "\n".join(lines)


@st.composite
def _scene_text(draw) -> str:
    """A scene document: mostly well-formed TOML with hostile values, sometimes raw text."""
    if draw(st.integers(0, 19)) == 0:
        return draw(st.text(max_size=200))
    speeds = draw(st.lists(_VALUE, min_size=draw(st.sampled_from([0, 1, 1, 1, 1])), max_size=3))
    lines = [f"mass = {draw(_VALUE)}", f"velocities = [{', '.join(speeds)}]"]
    if draw(st.integers(0, 4)) == 0:
        lines.append(f'kind = "{draw(st.sampled_from(["impact", "two-sided", "walls"]))}"')
    lines += ["[potential]", draw(_potential())]
    damping = draw(
        st.sampled_from([None, None, "zeta", "zeta", "restitution", "both", "none-with-zeta"])
    )
    if damping == "zeta":
        zeta = draw(st.one_of(st.floats(0.0, 0.99).map(lambda z: repr(round(z, 3))), _VALUE))
        lines += ["[damping]", 'law = "universal"', f"zeta = {zeta}"]
    elif damping == "restitution":
        e = draw(st.one_of(st.floats(0.05, 1.0).map(lambda x: repr(round(x, 3))), _VALUE))
        lines += ["[damping]", 'law = "universal"', f"restitution = {e}"]
    elif damping == "both":
        lines += ["[damping]", 'law = "universal"', "zeta = 0.1", "restitution = 0.5"]
    elif damping == "none-with-zeta":
        lines += ["[damping]", 'law = "none"', "zeta = 0.1"]
    return "\n".join(lines) + "\n"


def _finite_numbers(value, where="results") -> list[str]:
    """Paths of the non-finite numbers (NaN, inf, or the strings the CLI writes for them)."""
    bad = []
    if isinstance(value, float) and not math.isfinite(value):
        bad.append(where)
    elif isinstance(value, str) and value in ("inf", "-inf", "nan", "NaN"):
        bad.append(where)
    elif isinstance(value, dict):
        for k, v in value.items():
            bad += _finite_numbers(v, f"{where}.{k}")
    elif isinstance(value, list):
        for i, v in enumerate(value):
            bad += _finite_numbers(v, f"{where}[{i}]")
    return bad


def _check(capsys, argv: list[str], text: str) -> None:
    code = main(argv)
    out, err = capsys.readouterr()
    assert code in (0, 2), f"exit {code} for\n{text}\nstderr: {err}"
    if code == 2:
        lines = err.strip().splitlines()
        assert len(lines) == 1 and "Traceback" not in err, f"stderr for\n{text}\n{err}"
        assert out == "", out
    else:
        results = json.loads(out)["results"]
        assert results, text
        for row in results:
            if row.get("dt_safe") == 0.0:
                # x / dt_safe with dt_safe = 0 (U'' unbounded or U'(0) > 0): ratio and
                # accuracy_ratio are infinite by their definition, the only non-finite
                # numbers allowed
                row = {
                    k: v
                    for k, v in row.items()
                    if not (k in ("ratio", "accuracy_ratio") and v == "inf")
                }
            bad = _finite_numbers(row)
            assert not bad, f"non-finite {bad} for\n{text}"
            # By definition: durations and lengths >= 0, restitutions in [0, 1].
            for key in ("contact_time", "max_penetration", "dt_safe", "period"):
                assert not isinstance(row.get(key), float) or row[key] >= 0, (key, text)
            for key in ("restitution", "restitution_zero_force"):
                assert not isinstance(row.get(key), float) or 0 <= row[key] <= 1, (key, text)


_SETTINGS = dict(
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)


@settings(max_examples=60, **_SETTINGS)
@given(text=_scene_text())
def test_random_scenes_through_solve(tmp_path_factory, capsys, text):
    path = Path(tmp_path_factory.mktemp("s")) / "scene.toml"
    path.write_text(text, encoding="utf-8", errors="surrogatepass")
    _check(capsys, ["solve", str(path), "--json"], text)


@settings(max_examples=20, **_SETTINGS)
@given(text=_scene_text())
def test_random_scenes_through_dt_crit(tmp_path_factory, capsys, text):
    # A tiny criterion keeps each search short (two phases of the impact criterion).
    path = Path(tmp_path_factory.mktemp("d")) / "scene.toml"
    path.write_text(text, encoding="utf-8", errors="surrogatepass")
    _check(capsys, ["dt-crit", str(path), "--json", "--criterion", "tol=0.01,n_phases=2"], text)


@pytest.mark.parametrize(
    "text",
    [
        "mass = 1" + "0" * 400 + "\nvelocities = [1.0]\n[potential]\nfamily = 'power'\nk = 1.0\n"
        "p = 1.5\n",
        "mass = 1.0\nvelocities = " + "[" * 5000 + "]" * 5000 + "\n",
        "mass = 1.0\nvelocities = [" + ", ".join(["1.0"] * 300) + "]\n[potential]\n"
        "family = 'power'\nk = 1.0\np = 1.5\n",
        "mass = 1.0\nvelocities = [1.0]\n[potential]\nfamily = 'expression'\nU = '"
        + "+".join(["q**2"] * 1000)
        + "'\n",
    ],
)
def test_reported_hostile_scenes_are_one_line(tmp_path, capsys, text):
    """400-digit integer, arrays nested 5000 deep, 300 speeds, a 5000-character expression."""
    path = tmp_path / "s.toml"
    path.write_text(text)
    assert main(["solve", str(path)]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err


def test_ctrl_c_in_any_command_is_one_line_130(capsys, monkeypatch):
    """KeyboardInterrupt anywhere under cli.main: 'hcv: interrupted', exit 130."""
    from reference_impl import cli

    def interrupted(args):
        raise KeyboardInterrupt

    for command in (["solve", "hertz"], ["dt-crit", "hertz"], ["report"], ["scenes"]):
        parser = cli._parser()
        args = parser.parse_args(command)
        args.func = interrupted
        assert cli.run_command(args) == 130
        assert capsys.readouterr().err == "hcv: interrupted\n"


@pytest.mark.parametrize("zeta", ["0.9999", "0.99999", "2.0"])
def test_near_critical_damping_is_right_or_refused(tmp_path, capsys, zeta):
    """Issue 12, section 2: never a negative or non-finite time printed with exit 0."""
    path = tmp_path / "z.toml"
    path.write_text(
        "mass = 1.0\nvelocities = [1.0]\n[potential]\nfamily = 'power'\nk = 1.0\np = 1.0\n"
        f"[damping]\nlaw = 'universal'\nzeta = {zeta}\n"
    )
    _check(capsys, ["solve", str(path), "--json"], path.read_text())


def test_overdamped_contact_never_returning_is_an_answer_not_a_refusal(tmp_path, capsys):
    """Issue 12, section 2, zeta = 2 on Hertz: the zero-force end is finite and right.

    Reference: an independent ODE integration (the issue's 1.9032 s); the theory's end
    at q = 0 never comes for zeta >= 1 with a leading exponent >= 2, which the CLI states
    as contact_time = null with returns_to_q0 = false, never as a refusal or a number.
    """
    path = tmp_path / "od.toml"
    path.write_text(
        "mass = 1.0\nvelocities = [1.0]\n[potential]\nfamily = 'power'\nk = 1.0\np = 1.5\n"
        "[damping]\nlaw = 'universal'\nzeta = 2.0\n"
    )
    code = main(["solve", str(path), "--json"])
    out, err = capsys.readouterr()
    assert code == 0, f"got exit {code} ({err.strip()}), should be 0 [issue 12 s2, hcv solve]"
    row = json.loads(out)["results"][0]
    assert row["contact_time"] is None and row["returns_to_q0"] is False, (
        f"got contact_time {row['contact_time']!r}, returns_to_q0 {row['returns_to_q0']!r}, "
        "should be None and False [issue 12 s2, hcv solve zeta = 2]"
    )
    # The ODE reference is quoted to 5 significant digits (1.9032 s).
    assert abs(row["contact_time_zero_force"] - 1.9032) < 1e-4, (
        f"got {row['contact_time_zero_force']!r}, should be 1.9032 s (ODE) "
        "[issue 12 s2, hcv solve zeta = 2]"
    )


# ----------------------------------------------------------------------------
# issue 22: tracebacks that must be one line and exit 2
# ----------------------------------------------------------------------------
def _one_line_2(capsys, argv: list[str], needle: str = "") -> str:
    code = main(argv)
    out, err = capsys.readouterr()
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and "Traceback" not in err and needle in err, (
        f"got exit {code}, stderr {err[-400:]!r}, should be 2 with one line"
        f"{f' naming {needle!r}' if needle else ''} [issue 22, hcv {' '.join(argv[:1])}]"
    )
    return lines[0]


_LONG = "a" * 300  # one path component over the 255 bytes a Linux file system allows


@pytest.mark.parametrize(
    "argv",
    [
        ["solve", _LONG],
        ["solve", f"{_LONG}/scene.toml"],
        ["dt-crit", _LONG],
        ["report", "--out", _LONG],
        ["report", "--out", f"{_LONG}/x"],
        ["bench", "reference", "--scenes", f"{_LONG}.toml"],
        ["bench", "reference", "--json", f"{_LONG}.json"],
        ["bench", "reference", "--junit", f"{_LONG}/x.xml"],
        ["bench", "reference", "--tolerances", _LONG],
        ["bench", "reference", "--markdown", "é" * 200],  # 400 bytes in UTF-8
        ["sweep", _LONG],
        ["sweep", "SPEC", "--out", _LONG],
    ],
    ids=lambda a: " ".join(x[:12] for x in a),
)
def test_a_path_component_over_255_bytes_is_one_line_in_every_command(
    tmp_path, monkeypatch, capsys, argv
):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "SPEC").write_text(
        'task = "solve"\n[scene]\nmass = 1.0\nvelocities = [1.0]\n[scene.potential]\n'
        'family = "power"\nk = 1.0\np = 1.5\n[sweep]\nmass = [1.0, 2.0]\n'
    )
    _one_line_2(capsys, argv)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["SPEC"], "got files written"


_SWEEP_BASE = (
    'task = "solve"\n[scene]\nname = "m"\nmass = 1.0\nvelocities = [1.0]\n'
    '[scene.potential]\nfamily = "power"\nk = 1.0\np = 1.5\n'
)


@pytest.mark.parametrize(
    "sweep, needle",
    [
        ('"mass.x" = [1.0, 2.0]', "which is a value, not a table"),
        ('"name.x" = [1.0, 2.0]', "which is a value, not a table"),
        ('"potential.p.q" = [1.0, 2.0]', "which is a value, not a table"),
        ('"potential" = [1.0, 2.0]\n"potential.p" = [1.0, 2.0]', "overlap"),
        ('"potential.p" = [1.0, 2.0]\n"potential" = [{family = "power", k = 1, p = 2}]', "overlap"),
        ('"velocities" = [1.0, [1.0]]', "give the same scene"),
    ],
)
def test_sweep_keys_and_values_that_broke_the_expansion_are_one_line(
    tmp_path, capsys, sweep, needle
):
    path = tmp_path / "spec.toml"
    path.write_text(_SWEEP_BASE + "[sweep]\n" + sweep + "\n")
    _one_line_2(capsys, ["sweep", str(path), "--out", str(tmp_path / "out")], needle)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    "address, needle",
    [
        ("not-an-address", "is not a Dask scheduler address"),
        ("", "give the scheduler's address"),
        ("   ", "give the scheduler's address"),
        ("tcp://127.0.0.1", "is not a Dask scheduler address"),
        ("tcp://127.0.0.1:99999", "is not a Dask scheduler address"),
    ],
)
def test_bad_scheduler_addresses_are_one_line(tmp_path, capsys, address, needle):
    path = tmp_path / "spec.toml"
    path.write_text(_SWEEP_BASE + "[sweep]\nmass = [1.0, 2.0]\n")
    pytest.importorskip("distributed")
    argv = ["sweep", str(path), "--out", str(tmp_path / "out"), f"--scheduler={address}"]
    _one_line_2(capsys, argv, needle)
    assert not (tmp_path / "out").exists()
