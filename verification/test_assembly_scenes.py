"""Assembly scenes (issue 39, section 1): ``kind = "chain"`` and ``kind = "lattice"``.

They load through the scene loader, round-trip, are listed by ``hcv scenes``, build the
contact network they name, and bad input is one line naming the value (exit status 2
from ``hcv``), with nothing computed.
"""

from __future__ import annotations

import numpy as np
import pytest

from reference_impl.assembly.geometry import LATTICES, chain, coordination, lattice
from reference_impl.assembly.model import assembly_model
from reference_impl.errors import HCVInputError, SceneError
from reference_impl.scenes import AssemblyScene, load_scene, parse_scene
from verification._hcv_run import hcv
from verification.assertions import assert_true

_CHAIN = """
name = "c"
kind = "chain"
n = 4
mass = 0.01
walls = "both"
velocities = 0.1
{extra}
[potential]
family = "power"
k = 1.0e6
p = {p}
"""

_LATTICE = """
name = "l"
kind = "lattice"
lattice = "{name}"
cells = {cells}
mass = 0.01
radius = 0.005
velocities = 0.1
{extra}
[potential]
family = "power"
k = 1.0e6
p = 1.0
"""


def _chain(extra: str = "", p: str = "1.0") -> str:
    return _CHAIN.format(extra=extra, p=p)


def _refused(text: str, needle: str) -> str:
    with pytest.raises(HCVInputError) as info:
        parse_scene(text, "<t>")
    msg = str(info.value)
    assert_true(
        needle in msg and "<t>" in msg and "\n" not in msg,
        got=repr(msg),
        should=f"one line naming the scene and containing {needle!r}",
        claim="assembly scene",
        call="parse_scene",
    )
    return msg


@pytest.mark.parametrize(
    "extra, needle",
    [
        ("", "n = 0"),
        ("", "n = -3"),
    ],
)
def test_a_chain_without_bodies_is_refused(extra, needle):
    text = _chain(extra).replace("n = 4", needle)
    _refused(text, needle)


@pytest.mark.parametrize(
    "text, needle",
    [
        (_LATTICE.format(name="hexagonal", cells=3, extra=""), "'hexagonal' is not one of"),
        (_LATTICE.format(name="square", cells=1, extra=""), "cells must be an integer in [2"),
        (_LATTICE.format(name="square", cells="[3, 3, 3]", extra=""), "cells has 3 entries"),
        (_chain("gap = -1e-4"), "would overlap"),
        (_chain("gap = nan"), "gap must be a finite number"),
        (_chain().replace("mass = 0.01", "mass = [0.01, 0.02]"), "mass has 2 entries"),
        (_chain().replace("velocities = 0.1", "velocities = inf"), "velocities must be a finite"),
        (_chain("bonded = true\ngap = 1e-4"), "gap must be 0"),
        (_chain().replace('walls = "both"', 'walls = "left"'), "walls = 'left' is not one of"),
        (_chain("radius = 1.0"), "unknown key 'radius'"),
        (
            _LATTICE.format(name="square", cells=3, extra="tangential_ratio = 0.5"),
            "bonded linear springs only",
        ),
        (_chain("[damping]\nlaw = 'linear'\nc = 1.0"), "'none' or 'universal' only"),
    ],
)
def test_bad_assembly_input_is_one_line(text, needle):
    _refused(text, needle)


def test_bad_assembly_scene_exits_2_from_hcv_with_one_line(tmp_path):
    """``hcv dt-crit`` on an overlapping chain: one line on stderr, exit 2, nothing run."""
    path = tmp_path / "overlap.toml"
    path.write_text(_chain("gap = -1e-3"))
    r = hcv(["dt-crit", str(path), "--json"], cwd=tmp_path)
    lines = r.stderr.strip().splitlines()
    assert_true(
        r.returncode == 2 and len(lines) == 1 and "would overlap" in lines[0] and not r.stdout,
        got=f"exit {r.returncode}, stderr {r.stderr!r}, stdout {r.stdout[:80]!r}",
        should="exit 2, one line naming the gap, no output",
        claim="assembly scene",
        call="hcv dt-crit overlap.toml",
    )


def test_hcv_solve_refuses_an_assembly_in_one_line(tmp_path):
    r = hcv(["solve", "chain-linear"], cwd=tmp_path)
    assert_true(
        r.returncode == 2 and "'chain'" in r.stderr and len(r.stderr.strip().splitlines()) == 1,
        got=f"exit {r.returncode}, stderr {r.stderr!r}",
        should="exit 2, one line: a chain has no single impact",
        claim="assembly scene",
        call="hcv solve chain-linear",
    )


def test_hcv_scenes_lists_the_assembly_scenes(tmp_path):
    r = hcv(["scenes"], cwd=tmp_path)
    rows = {line.split()[0]: line for line in r.stdout.splitlines() if line.strip()}
    for name, shape in (("chain-hertz", "n=10 walls=both"), ("lattice-fcc-rotation", "fcc")):
        assert_true(
            r.returncode == 0 and name in rows and shape in rows[name],
            got=repr(rows.get(name)),
            should=f"a row for {name} naming {shape!r}",
            claim="assembly scene",
            call="hcv scenes",
        )


@pytest.mark.parametrize("name", ["chain-hertz", "chain-linear", "lattice-hertz-triangular",
                                  "lattice-fcc-rotation"])  # fmt: skip
def test_shipped_assembly_scenes_build_what_they_name(name):
    scene = load_scene(name)
    model = assembly_model(scene)
    a = model.assembly
    f = scene.assembly
    want_n = f.n_bodies
    assert_true(
        isinstance(scene, AssemblyScene)
        and a.n_bodies == want_n
        and float(np.linalg.norm(model.v_init[0])) == scene.velocities[0]
        and np.count_nonzero(model.v_init) == a.dim
        and model.bonded == f.bonded,
        got=f"{type(scene).__name__}, {a.n_bodies} bodies, v_init[0] = {model.v_init[0]}",
        should=f"an AssemblyScene of {want_n} bodies, only the striker moving at v0",
        claim="assembly scene",
        call=f"assembly_model(load_scene({name!r}))",
    )


def test_chain_walls_and_striker_layout():
    """walls none / one (right end) / both; the striker starts touching its right
    neighbour with a gap on its left; every other contact has the gap."""
    g = 1e-4
    for walls, n_walls in (("none", 0), ("one", 1), ("both", 2)):
        a = chain([1.0] * 3, walls, g)
        q = a.off + np.sum((a.u0[a.ci] - np.where(a.cj[:, None] >= 0, a.u0[a.cj], 0.0))
                           * a.normal, axis=1)  # fmt: skip
        striker_right = q[(a.ci == 0) & (a.cj == 1)]
        others = np.delete(q, np.flatnonzero((a.ci == 0) & (a.cj == 1)))
        assert_true(
            np.count_nonzero(a.cj < 0) == n_walls
            and striker_right.tolist() == [0.0]
            and np.all(others == -g),
            got=f"{np.count_nonzero(a.cj < 0)} walls, overlaps {q.tolist()}",
            should=f"{n_walls} walls, 0 at the striker's right contact, -gap elsewhere",
            claim="assembly scene",
            call=f"chain(walls={walls!r})",
        )


@pytest.mark.parametrize("name", LATTICES)
def test_every_lattice_has_its_coordination_number(name):
    """Periodic: N Z / 2 contacts, every body Z of them; walled: the same Z, walls counted."""
    z = coordination(name)
    for periodic in (True, False):
        a = lattice(name, 3, 1.0, 0.5, periodic=periodic)
        counts = np.bincount(np.concatenate([a.ci, a.cj[a.cj >= 0]]), minlength=a.n_bodies)
        walls = np.count_nonzero(a.cj < 0)
        lengths = np.linalg.norm(a.normal, axis=1)
        assert_true(
            np.all(counts == z)
            and np.allclose(lengths, 1.0, rtol=1e-12)
            and (walls == 0) == periodic,
            got=f"contacts per body {sorted(set(counts.tolist()))}, {walls} walls",
            should=f"{z} each, unit normals, walls only when walled",
            claim="assembly scene",
            call=f"lattice({name!r}, periodic={periodic})",
        )


def test_a_periodic_lattice_needs_two_cells():
    with pytest.raises(HCVInputError, match="cells >= 2"):
        lattice("square", 1, 1.0, 0.5)
    with pytest.raises(SceneError, match="unknown key"):
        parse_scene(_LATTICE.format(name="square", cells=3, extra="walls = 'both'"), "<t>")
