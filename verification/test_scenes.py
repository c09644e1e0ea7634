"""Scene files: every embedded scene loads with the paper's numbers; bad scenes are refused.

Each refusal must be a one-line `SceneError` that names the scene and the
offending key or value (or, for a potential that breaks the paper's
assumptions, the potential's own error type with the scene named).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from reference_impl.errors import (
    ExpressionError,
    HCVInputError,
    NonMonotoneError,
    NoTurningPointError,
    SceneError,
)
from reference_impl.potentials import Ellipsoid, Expression, PowerLaw, Sphere, SumPotential
from reference_impl.scenes import (
    Scene,
    embedded_scenes,
    load_scene,
    parse_scene,
    scene_from_dict,
)
from reference_impl.theory.damping import restitution_from_zeta, zeta_from_restitution
from verification.assertions import assert_close, assert_true

_REQUIRED_EMBEDDED = (
    "paper-ellipsoid",
    "paper-ellipsoid-damped",
    "hertz",
    "hertz-damped",
    "sphere",
)
_TABLE1_SPEEDS = (0.50, 0.99, 1.50)
# Steel sphere of hertz.toml: E = 210 GPa, nu = 0.3, R = 5 mm, rho = 7850 kg/m^3.
_STEEL_E, _STEEL_NU, _HERTZ_R, _STEEL_RHO = 210e9, 0.3, 0.005, 7850.0
# The TOML file quotes k and m to 5 significant digits.
_QUOTED_RTOL = 1e-4

_BASE = """
mass = 0.05
velocities = [0.5]
kind = "impact"
[potential]
family = "power"
k = 1e6
p = 1.5
"""


def _refused(text: str, needle: str, error=SceneError, source: str = "bad.toml"):
    """parse_scene(text) must raise ``error`` with a one-line message naming the scene."""
    with pytest.raises(error) as info:
        parse_scene(text, source)
    msg = str(info.value)
    assert_true(
        needle in msg and source in msg and "\n" not in msg,
        got=repr(msg),
        should=f"one line naming {source!r} and containing {needle!r}",
        claim="scene",
        call=f"parse_scene(<{needle}>)",
    )
    return info.value


# -- embedded scenes -----------------------------------------------------------------


def test_required_scenes_are_embedded():
    missing = sorted(set(_REQUIRED_EMBEDDED) - set(embedded_scenes()))
    assert_true(
        not missing,
        got=f"missing {missing}",
        should="none",
        claim="scene",
        call="embedded_scenes()",
    )


@pytest.mark.parametrize("name", embedded_scenes())
def test_every_embedded_scene_loads_and_round_trips(name):
    scene = load_scene(name)
    assert_true(
        isinstance(scene, Scene) and scene.name == name,
        got=repr(scene.name),
        should=name,
        claim="scene",
        call=f"load_scene({name!r})",
    )
    data = scene.to_dict()
    json.dumps(data)  # JSON-safe for reports
    again = scene_from_dict({k: v for k, v in data.items() if k != "source"}, "round-trip")
    again_data = again.to_dict()
    again_data["source"] = data["source"]
    assert_true(
        again_data == data,
        got=str(again_data),
        should=str(data),
        claim="scene",
        call=f"scene_from_dict(to_dict()) for {name}",
    )


def test_paper_ellipsoid_has_the_papers_numbers():
    scene = load_scene("paper-ellipsoid")
    pot = scene.potential
    assert_true(
        isinstance(pot, Ellipsoid)
        and (pot.a, pot.b, pot.c, pot.Kn, pot.alpha) == (0.015, 0.008, 0.008, 1e8, 0.5)
        and scene.mass == 0.05
        and scene.velocities == _TABLE1_SPEEDS
        and scene.damping_law == "none"
        and scene.zeta is None
        and scene.kind == "impact",
        got=str(scene.to_dict()),
        should="section 10 / Table 1 values",
        claim="scene",
        call="load_scene('paper-ellipsoid')",
    )


def test_paper_ellipsoid_damped_converts_fig1_constants():
    """C0 = 0.5 with K = 1, M = 0.75 (Fig. 1) is zeta = C0 / (2 sqrt(K M))."""
    scene = load_scene("paper-ellipsoid-damped")
    assert_close(
        scene.zeta,
        0.5 / (2.0 * math.sqrt(0.75)),
        rtol=1e-15,
        claim="scene",
        call="paper-ellipsoid-damped zeta",
    )
    assert_true(
        scene.damping_law == "universal" and scene.velocities == _TABLE1_SPEEDS,
        got=str(scene.to_dict()),
        should="universal, Table 1 speeds",
        claim="scene",
        call="load_scene('paper-ellipsoid-damped')",
    )


def test_hertz_scenes_are_a_steel_sphere():
    """k = (4/3) E* sqrt(R), E* = E / (2 (1 - nu^2)); m = rho 4/3 pi R^3; hertz-damped zeta 0.1."""
    e_star = _STEEL_E / (2.0 * (1.0 - _STEEL_NU**2))
    k = 4.0 / 3.0 * e_star * math.sqrt(_HERTZ_R)
    m = _STEEL_RHO * 4.0 / 3.0 * math.pi * _HERTZ_R**3
    for name, zeta in (("hertz", None), ("hertz-damped", 0.1)):
        scene = load_scene(name)
        assert_true(
            isinstance(scene.potential, PowerLaw)
            and scene.potential.p == 1.5
            and scene.zeta == zeta,
            got=str(scene.to_dict()),
            should=f"PowerLaw p = 1.5, zeta {zeta}",
            claim="scene",
            call=name,
        )
        assert_close(scene.potential.k, k, rtol=_QUOTED_RTOL, claim="scene", call=f"{name} k")
        assert_close(scene.mass, m, rtol=_QUOTED_RTOL, claim="scene", call=f"{name} mass")


def test_sphere_scene():
    scene = load_scene("sphere")
    assert_true(
        isinstance(scene.potential, Sphere),
        got=repr(scene.potential),
        should="Sphere",
        claim="scene",
        call="load_scene('sphere')",
    )


def test_load_from_path_and_pathlike(tmp_path):
    path = tmp_path / "mine.toml"
    path.write_text(_BASE)
    for arg in (str(path), path):
        scene = load_scene(arg)
        assert_true(
            scene.name == "mine" and scene.source == str(path),
            got=repr(scene),
            should="name from the file stem, source = path",
            claim="scene",
            call=f"load_scene({arg!r})",
        )


def test_sum_and_expression_families():
    text = """
    mass = 0.01
    velocities = [0.2, 1]
    [potential]
    family = "sum"
    [[potential.terms]]
    family = "power"
    k = 1e5
    p = 1
    [[potential.terms]]
    family = "expression"
    U = "c*q**3"
    params = { c = 2e9 }
    """
    scene = parse_scene(text, "sum.toml")
    pot = scene.potential
    assert_true(
        isinstance(pot, SumPotential)
        and isinstance(pot.terms[1], Expression)
        and scene.velocities == (0.2, 1.0)
        and scene.name == "sum",
        got=repr(pot),
        should="PowerLaw + Expression",
        claim="scene",
        call="sum scene",
    )
    assert_close(
        pot.U(1e-3), 1e5 * 1e-6 / 2 + 2e9 * 1e-9, rtol=1e-15, claim="scene", call="sum U(1e-3)"
    )


@pytest.mark.parametrize(
    "damping,zeta",
    [
        ("zeta = 0.25", 0.25),
        ("zeta = 0", 0.0),
        ("restitution = 0.8", zeta_from_restitution(0.8)),
        ("restitution = 1", 0.0),
        ("C0 = 3.0\nK = 4.0\nM = 9.0", 3.0 / (2.0 * 6.0)),
    ],
)
def test_damping_forms(damping, zeta):
    scene = parse_scene(_BASE + f'[damping]\nlaw = "universal"\n{damping}\n', "damped.toml")
    assert_close(scene.zeta, zeta, rtol=1e-15, atol=1e-300, claim="scene", call=damping)
    if damping.startswith("restitution"):
        e = float(damping.split("=")[1])
        assert_close(
            restitution_from_zeta(scene.zeta),
            e,
            rtol=1e-14,
            claim="scene",
            call="restitution round trip",
        )


def test_two_walls_with_gap():
    scene = parse_scene(_BASE.replace('kind = "impact"', 'kind = "two-walls"\ngap = 0.01'), "w")
    assert_true(
        scene.kind == "two-walls" and scene.gap == 0.01,
        got=repr(scene),
        should="gap",
        claim="scene",
        call="two-walls",
    )


# -- refusals ---------------------------------------------------------------------


def test_missing_file_and_unknown_name(tmp_path):
    for arg, needle in (
        (str(tmp_path / "nope.toml"), "not found"),
        (tmp_path, "is not a regular file"),
        ("no-such-scene", "embedded: "),
    ):
        with pytest.raises(SceneError) as info:
            load_scene(arg)
        msg = str(info.value)
        assert_true(
            needle in msg and "\n" not in msg,
            got=msg,
            should=f"contains {needle!r}",
            claim="scene",
            call=f"load_scene({arg!r})",
        )


def test_unreadable_files(tmp_path):
    binary = tmp_path / "bin.toml"
    binary.write_bytes(b"mass = 1\n\xff\xfe")
    huge = tmp_path / "huge.toml"
    huge.write_text("# " + "x" * 1_100_000)
    for path, needle in ((binary, "not UTF-8"), (huge, "too large")):
        with pytest.raises(SceneError, match=needle):
            load_scene(path)


def test_toml_syntax_error_names_the_line():
    _refused(_BASE + "gap = = 1\n", "TOML syntax error")
    _refused(_BASE + "gap = = 1\n", "line 9")


_SWAP = [
    # (old text in _BASE, new text, message must contain)
    ("mass = 0.05", "", "missing key 'mass'"),
    ("velocities = [0.5]", "", "missing key 'velocities'"),
    ('family = "power"', "", "missing key 'potential.family'"),
    ("k = 1e6", "", "missing key 'potential.k'"),
    ("mass = 0.05", "mas = 0.05", "unknown key 'mas' (did you mean 'mass'?)"),
    ("k = 1e6", "k = 1e6\nkk = 2", "unknown key 'potential.kk'"),
    ("mass = 0.05", 'mass = "0.05"', "mass must be a number, got '0.05'"),
    ("mass = 0.05", "mass = true", "mass must be a number, got True"),
    ("mass = 0.05", "mass = 0", "mass must be > 0, got 0"),
    ("mass = 0.05", "mass = -1.0", "mass must be > 0"),
    ("mass = 0.05", "mass = nan", "mass must be a finite number, got nan"),
    ("mass = 0.05", "mass = inf", "mass must be a finite number, got inf"),
    ("velocities = [0.5]", "velocities = []", "velocities must be a non-empty array"),
    ("velocities = [0.5]", "velocities = 0.5", "velocities must be a non-empty array"),
    ("velocities = [0.5]", "velocities = [0.5, 0]", "velocities[1] must be > 0, got 0"),
    ("velocities = [0.5]", "velocities = [-0.5]", "velocities[0] must be > 0"),
    ("velocities = [0.5]", "velocities = [nan]", "velocities[0] must be a finite number"),
    ("velocities = [0.5]", "velocities = [inf]", "velocities[0] must be a finite number"),
    ("velocities = [0.5]", 'velocities = ["fast"]', "velocities[0] must be a number"),
    ('kind = "impact"', 'kind = "impakt"', "kind = 'impakt' is not one of"),
    ('kind = "impact"', "kind = 3", "kind must be a non-empty string"),
    ('kind = "impact"', 'kind = "two-walls"', "needs gap"),
    ('kind = "impact"', 'kind = "two-walls"\ngap = 0', "gap must be > 0"),
    ('kind = "impact"', 'kind = "two-walls"\ngap = nan', "gap must be a finite number"),
    ('kind = "impact"', 'kind = "impact"\ngap = 0.01', "gap applies to kind = 'two-walls' only"),
    ('family = "power"', 'family = "powerlaw"', "potential.family = 'powerlaw' is not one of"),
    ("k = 1e6", "k = -1e6", "potential.k must be > 0"),
    ("k = 1e6", "k = nan", "potential.k must be a finite number"),
    ("p = 1.5", 'p = "1.5"', "potential.p must be a number"),
    ("[potential]\n", "potential = 5\n[potentials]\n", "unknown key 'potentials'"),
]


@pytest.mark.parametrize("old,new,needle", _SWAP)
def test_bad_top_level_and_potential_values(old, new, needle):
    assert old in _BASE
    _refused(_BASE.replace(old, new, 1), needle)


@pytest.mark.parametrize(
    "damping,needle",
    [
        ("law = 'universal'\nzeta = 0.1\nrestitution = 0.8", "exactly one of"),
        ("law = 'universal'", "exactly one of zeta, restitution or C0"),
        ("law = 'universal'\nzeta = -0.1", "damping.zeta must be >= 0"),
        ("law = 'universal'\nzeta = nan", "damping.zeta must be a finite number"),
        ("law = 'universal'\nrestitution = 0", "damping.restitution must be > 0 and <= 1"),
        ("law = 'universal'\nrestitution = 1.5", "damping.restitution must be > 0 and <= 1"),
        ("law = 'universal'\nrestitution = -0.2", "damping.restitution must be > 0"),
        ("law = 'universal'\nC0 = 0.5\nK = 1.0", "damping.C0 needs damping.M"),
        ("law = 'universal'\nC0 = 0.5\nK = 0\nM = 1", "damping.K must be > 0"),
        ("law = 'universal'\nC0 = -0.5\nK = 1\nM = 1", "damping.C0 must be >= 0"),
        ("law = 'universal'\nzeta = 0.1\nK = 1.0", "go with damping.C0 only"),
        ("zeta = 0.1", "damping.law is 'none'"),
        ("law = 'none'\nrestitution = 0.9", "damping.law is 'none'"),
        ("law = 'tsuji'", "damping.law = 'tsuji' is not one of"),
        # issue 26 item 7: the underscore spelling is named, not just refused
        ("law = 'hunt_crossley'\nalpha = 0.1", "(did you mean 'hunt-crossley'?)"),
        ("law = 'universal'\nzeta = 0.1\nzeta_ = 1", "unknown key 'damping.zeta_'"),
    ],
)
def test_bad_damping(damping, needle):
    _refused(_BASE + "[damping]\n" + damping + "\n", needle)


def test_viscoelastic_on_a_force_exponent_below_1_names_the_scene():
    """Issue 26 item 7: refused when the scene is read, with the "scene FILE:" prefix."""
    text = _BASE.replace("p = 1.5", "p = 0.5") + "[damping]\nlaw = 'viscoelastic'\nA = 1e-5\n"
    _refused(text, "damping law 'viscoelastic' needs U'' finite at contact")


def test_damping_not_a_table():
    _refused("damping = 1\n" + _BASE, "damping must be a table")


def test_sum_needs_two_terms():
    text = _BASE.replace(
        'family = "power"\nk = 1e6\np = 1.5',
        'family = "sum"\n[[potential.terms]]\nfamily = "power"\nk = 1\np = 1',
    )
    _refused(text, "potential.terms must be an array of at least two")


def test_bad_term_is_named_by_path():
    text = _BASE.replace(
        'family = "power"\nk = 1e6\np = 1.5',
        'family = "sum"\n[[potential.terms]]\nfamily = "power"\nk = 1\np = 1\n'
        '[[potential.terms]]\nfamily = "sphere"\nR = 0.01\nKn = -1',
    )
    _refused(text, "potential.terms[1].Kn must be > 0")


def _expression_scene(U: str, params: str = "", velocities: str = "[0.5]") -> str:
    return (
        f'mass = 0.05\nvelocities = {velocities}\n[potential]\nfamily = "expression"\n'
        f"U = {json.dumps(U)}\n" + (f"params = {{ {params} }}\n" if params else "")
    )


def test_expression_errors_keep_their_type_and_name_the_scene():
    err = _refused(
        _expression_scene("__import__('os').system('echo pwned')"), "'__import__'", ExpressionError
    )
    assert_true(
        isinstance(err, HCVInputError),
        got=type(err).__name__,
        should="HCVInputError",
        claim="scene",
        call="hostile U",
    )
    _refused(_expression_scene("k*q**2", "k = nan"), "potential.params.k must be a finite")
    _refused(_expression_scene("1 + q"), "U(0) = 1 but assumption (2)", HCVInputError)
    _refused(
        _expression_scene("k*q**2", "k = 1, z = 2"), "parameter 'z' is not used", ExpressionError
    )


def test_non_monotone_potential_is_refused():
    """U = q^2 - q^3 peaks at 4/27 J: 0.05 kg at 0.5 m/s (6.25e-3 J) is fine, 3 m/s is not."""
    parse_scene(_expression_scene("q**2 - q**3"), "ok.toml")
    _refused(
        _expression_scene("q**2 - q**3", velocities="[0.5, 3.0]"),
        "velocity 3 m/s (E = 0.225 J)",
        NonMonotoneError,
    )


def test_no_turning_point_is_refused():
    """U = 1 - exp(-q) < 1 J and an ellipsoid beyond its 2a range: no turning point."""
    _refused(
        _expression_scene("1 - exp(-q)", velocities="[7.0]"),
        "levels off at 1 J",
        NoTurningPointError,
    )
    text = load_scene_text("paper-ellipsoid").replace("[0.50, 0.99, 1.50]", "[0.5, 400.0]")
    _refused(text, "velocity 400 m/s", NoTurningPointError)


def load_scene_text(name: str) -> str:
    from importlib import resources

    return (resources.files("reference_impl.scenes") / f"{name}.toml").read_text()


def test_embedded_files_have_a_source_comment():
    """Each shipped scene says where its numbers come from (a leading comment)."""
    for name in embedded_scenes():
        first = load_scene_text(name).lstrip().splitlines()[0]
        assert_true(
            first.startswith("#"),
            got=repr(first),
            should="a comment line",
            claim="scene",
            call=f"{name}.toml",
        )


def test_scene_is_frozen():
    scene = load_scene("hertz")
    with pytest.raises(AttributeError):
        scene.mass = 1.0  # type: ignore[misc]


def test_parse_scene_rejects_non_text():
    with pytest.raises(SceneError, match="must be a string"):
        parse_scene(b"mass = 1", "bytes")  # type: ignore[arg-type]


def test_bad_path_type():
    with pytest.raises(SceneError):
        load_scene(3)  # type: ignore[arg-type]


def test_source_in_message_is_the_path(tmp_path):
    path = tmp_path / "typo.toml"
    path.write_text(_BASE.replace("mass", "mas"))
    with pytest.raises(SceneError, match=str(Path(path)).replace("\\", "\\\\")):
        load_scene(path)


# -- one catalogue (issue 17, first hour item 2) -------------------------------------------
def test_every_scene_name_the_speed_table_and_report_show_is_in_the_catalogue():
    """The work-precision study and the README's speed table name their scenes; each name
    loads in every command (``load_scene``), and the four family rows are read from it."""
    import math

    from reference_impl.studies.workprecision import default_scenes, family_scenes

    names = embedded_scenes()
    for wp in [*family_scenes(), *default_scenes()]:
        assert wp.name in names, (
            f"got {wp.name!r} missing, should be in {names} [one catalogue, load_scene]"
        )
    sphere = load_scene("sphere-damped")
    want = 7800.0 * 4.0 / 3.0 * math.pi * 0.01**3
    assert abs(sphere.mass - want) <= 1e-15 * want, (
        f"got {sphere.mass!r}, should be {want!r} [sphere-damped mass, steel R = 10 mm]"
    )


def test_scenes_show_prints_a_scene_toml_that_loads_back(tmp_path):
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parent.parent
    r = subprocess.run(
        [sys.executable, "-m", "reference_impl.cli", "scenes", "--show", "power-sum-damped"],
        cwd=root, capture_output=True, text=True, timeout=120,
        env={"PYTHONPATH": str(root), "PATH": "/usr/bin:/bin"},
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    back = parse_scene(r.stdout, "shown")
    want = load_scene("power-sum-damped").to_dict()
    got = back.to_dict()
    assert (got["potential"], got["mass"], got["damping"]) == (
        want["potential"],
        want["mass"],
        want["damping"],
    ), f"got {got}, should be {want} [hcv scenes --show]"
    bad = subprocess.run(
        [sys.executable, "-m", "reference_impl.cli", "scenes", "--show", "no-such-scene"],
        cwd=root, capture_output=True, text=True, timeout=120,
        env={"PYTHONPATH": str(root), "PATH": "/usr/bin:/bin"},
    )  # fmt: skip
    assert bad.returncode == 2 and len(bad.stderr.strip().splitlines()) == 1, bad.stderr
