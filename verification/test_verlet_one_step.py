"""Tool tests of the one velocity-Verlet step (issue 27, goal 7: one source per loop).

The step (half kick, drift, overlap, force, damping, half kick) is written once,
`reference_impl.integrators.verlet_kernel._kdk`, and bound to the term-table force (the
lane kernel and the recorder, compiled), to an expression's compiled force (the lane
kernel specialised) and to a Python potential's force (the recorder run as Python).
Held here: the lane engine against the kernel as it stood before, frozen in
`verification/_frozen_verlet_lanes.py`, bit for bit (every float's bits: signed zeros
and nan included) on impact, two-walls and two-sided scenes with damping, confirmation,
skip-after-fail, checkpoints, a blow-up, an end-energy failure, chunked resumption and a
compiled expression; and the rule itself, by reading the source. The recorder is held to
its own frozen copies in `verification/test_tools_verlet_recorder.py`.
"""

from __future__ import annotations

import ast
import pathlib

import numba
import numpy as np
import pytest
import sympy as sp

import reference_impl
import reference_impl.integrators.verlet as verlet
from reference_impl.integrators.verlet import SCENE_IMPACT, SCENE_WALLS, LaneBatch, run_lanes
from reference_impl.potentials import Ellipsoid, Expression, PowerLaw, SaturatingForce
from verification._frozen_verlet_lanes import frozen_kernel
from verification.assertions import assert_true

_HERTZ = PowerLaw(1.0, 1.5)
_LINEAR = PowerLaw(1.0, 1.0)
_ELL = Ellipsoid(0.015, 0.008, 0.008, 1e8, 0.5)
_SAT = SaturatingForce(2.0, 0.3)
# dt spread across the stability limit (~1.75 s for Hertz with m = v0 = 1): stable lanes,
# bounded excursions and runaways in one batch.
_DT = np.linspace(0.2, 3.0, 11)


def _batch(**kw) -> LaneBatch:
    base = dict(dt=_DT, y0=0.0, v0=1.0, gap=0.0, e_limit=50.0, max_steps=3000)
    base.update(kw)
    return LaneBatch(**base)


# (potential, mass, scene, batch, run_lanes keywords)
CASES = {
    "two-sided": (_HERTZ, 1.0, SCENE_WALLS, _batch(), {}),
    "two-sided-confirm": (
        _LINEAR,
        1.0,
        SCENE_WALLS,
        _batch(dt=np.linspace(1.99, 2.01, 9), e_limit=10.0, e_confirm=5e4, confirm_steps=6000),
        {},
    ),
    "two-walls-damped": (_HERTZ, 1.0, SCENE_WALLS, _batch(gap=0.7), {"zeta": 0.05}),
    "two-walls-skip-groups": (
        _HERTZ,
        1.0,
        SCENE_WALLS,
        _batch(gap=0.3, group=np.arange(11) % 3),
        {"skip_after_fail": True, "checkpoints": [1, 10, 100, 1000, 2999]},
    ),
    "impact": (_HERTZ, 1.0, SCENE_IMPACT, _batch(e_final=0.5 + 1e-3), {}),
    "impact-damped-in-contact": (
        _HERTZ,
        1.0,
        SCENE_IMPACT,
        _batch(y0=0.3, v0=np.linspace(-1.0, 1.0, 11)),
        {"zeta": 0.3, "checkpoints": [2, 50]},
    ),
    "impact-blown": (_ELL, 0.05, SCENE_IMPACT, _batch(dt=np.geomspace(1e-6, 1e-3, 11), v0=5.0), {}),
    "two-sided-ellipsoid": (
        _ELL,
        0.05,
        SCENE_WALLS,
        _batch(dt=np.geomspace(1e-6, 1e-4, 11), v0=0.99, e_limit=1.0),
        {"zeta": 0.1},
    ),
    "two-walls-saturating": (_SAT, 1.0, SCENE_WALLS, _batch(gap=0.2), {"block": 3}),
}


def _bits(res) -> list[np.ndarray]:
    return [
        np.asarray(a).view(np.int64)
        for a in (res.status, res.steps, res.e_max, res.e_end, res.hist)
    ]


def _same_bits(got, old, call: str) -> None:
    g, o = _bits(got), _bits(old)
    same = all(a.shape == b.shape and np.array_equal(a, b) for a, b in zip(g, o, strict=True))
    bad = [
        name
        for name, a, b in zip(("status", "steps", "e_max", "e_end", "hist"), g, o, strict=True)
        if not (a.shape == b.shape and np.array_equal(a, b))
    ]
    assert_true(
        same,
        got=f"fields {bad} differing from the frozen kernel",
        should="the same bits in every field",
        claim="tool",
        call=call,
    )


@pytest.mark.parametrize("name", sorted(CASES))
def test_lane_engine_is_the_frozen_kernel_bit_for_bit(name, monkeypatch):
    pot, m, scene, batch, kw = CASES[name]
    new = run_lanes(pot, m, scene, batch, engine="numba", **kw)
    monkeypatch.setattr(verlet, "_kernel", frozen_kernel())
    old = run_lanes(pot, m, scene, batch, engine="numba", **kw)
    _same_bits(new, old, f"run_lanes({name})")


def test_chunked_lanes_are_the_frozen_kernel_bit_for_bit(monkeypatch):
    """Resumed every 7 lane-steps (saved and reloaded state): still the frozen bits."""
    pot, m, scene, batch, kw = CASES["two-walls-skip-groups"]
    monkeypatch.setattr(verlet, "_CHUNK_LANE_STEPS", 7)
    new = run_lanes(pot, m, scene, batch, engine="numba", **kw)
    monkeypatch.setattr(verlet, "_kernel", frozen_kernel())
    old = run_lanes(pot, m, scene, batch, engine="numba", **kw)
    _same_bits(new, old, "run_lanes(chunks of 7 lane-steps)")


def test_compiled_expression_lanes_are_the_frozen_kernel_bit_for_bit(monkeypatch):
    """The lane kernel bound to an expression's compiled force: the frozen kernel with it."""
    expr = Expression("q**2.5/2.5 + q**3*exp(-q)/3")
    q = next(iter(expr.expr.free_symbols))
    fn = numba.njit(error_model="numpy")(sp.lambdify(q, (expr.dexpr, expr.expr), modules="math"))

    @numba.njit(inline="always", error_model="numpy")
    def force_energy(x, fam, par):
        a, b = fn(x)
        return float(a), float(b)

    batch = _batch(e_confirm=5e5, confirm_steps=6000, gap=0.1)
    new = run_lanes(expr, 1.0, SCENE_WALLS, batch, engine="numba", zeta=0.02)
    assert_true(
        new.engine == "numba",
        got=new.engine,
        should="numba",
        claim="tool",
        call="run_lanes(Expression, engine='numba')",
    )
    monkeypatch.setattr(verlet, "_expression_kernel", lambda pot: frozen_kernel(force_energy))
    old = run_lanes(expr, 1.0, SCENE_WALLS, batch, engine="numba", zeta=0.02)
    _same_bits(new, old, "run_lanes(Expression, engine='numba')")


# ----------------------------------------------------------------------------
# the rule: one velocity-Verlet update in the package
# ----------------------------------------------------------------------------
# The one function allowed to write the scalar step, and the numpy lanes engine, kept
# because it measures faster than the step run as Python for its use (many lanes of a
# potential without a compiled force; the figure is in its comment).
_ONE_STEP = "integrators/verlet_kernel.py:_kdk"
_NUMPY_LANES = "integrators/verlet.py:_run_numpy"


def _kick(node, kicks: set[str] | None = None) -> bool:
    """``a + b * c`` (a kick: a velocity plus a step times a force), with ``a`` one of
    ``kicks`` when given."""
    if not (isinstance(node, ast.BinOp) and isinstance(node.op, ast.Add)):
        return False
    if not isinstance(node.right, ast.BinOp) or not isinstance(node.right.op, ast.Mult):
        return False
    return kicks is None or (isinstance(node.left, ast.Name) and node.left.id in kicks)


def _uses(node, names: set[str]) -> bool:
    return any(isinstance(n, ast.Name) and n.id in names for n in ast.walk(node))


def _verlet_updates(tree: ast.AST) -> list[str]:
    """Functions that write a velocity-Verlet update: a half kick ``vh = v + c * F``, a
    drift using ``vh`` (``y = y + dt * vh`` or ``y += dt * vh``) and a second kick from
    ``vh`` by a force (``vh + c * F``, assigned to another name or not at all)."""
    found = []
    for fn in ast.walk(tree):
        if not isinstance(fn, ast.FunctionDef):
            continue
        kicks = {
            t.id
            for node in ast.walk(fn)
            if isinstance(node, ast.Assign) and _kick(node.value)
            for t in node.targets
            if isinstance(t, ast.Name)
        }
        drift = any(
            (isinstance(node, ast.Assign) and _kick(node.value) and _uses(node.value.right, kicks))
            or (
                isinstance(node, ast.AugAssign)
                and isinstance(node.op, ast.Add)
                and isinstance(node.value, ast.BinOp)
                and isinstance(node.value.op, ast.Mult)
                and _uses(node.value, kicks)
            )
            for node in ast.walk(fn)
        )
        # ``v = v + c * F`` updates v in place (symplectic Euler's kick), not from a half step.
        in_place = {
            id(node.value)
            for node in ast.walk(fn)
            if isinstance(node, ast.Assign)
            and _kick(node.value)
            and isinstance(node.value.left, ast.Name)
            and any(isinstance(t, ast.Name) and t.id == node.value.left.id for t in node.targets)
        }
        second = any(
            _kick(node, kicks) and not _uses(node.right, kicks) and id(node) not in in_place
            for node in ast.walk(fn)
        )
        if kicks and drift and second:
            found.append(fn.name)
    return found


def _check_the_scanner() -> None:
    """The scan finds a step in each spelling (the check can fail), and not symplectic Euler."""
    src = (
        "def a(v, y, F, half, dt):\n    vh = v + half * F\n    y = y + dt * vh\n"
        "    v = vh + half * F\n    return y, v\n"
        "def b(v, y, F, half, dt):\n    vh = v + half * F\n    y += dt * vh\n"
        "    return y, vh + half * F\n"
        "def c(v, y, F, dt):\n    v = v + dt * F\n    y = y + dt * v\n    return y, v\n"
    )
    found = _verlet_updates(ast.parse(src))
    assert_true(
        found == ["a", "b"],
        got=found,
        should="['a', 'b'] (c is symplectic Euler: one full kick, no half step)",
        claim="tool",
        call="_verlet_updates(synthetic)",
    )


def test_the_velocity_verlet_step_is_written_once():
    """No module of the package writes a velocity-Verlet update but `_kdk` (and the numpy
    lanes engine, kept for its measured speed); fails on main, where the lane kernel and
    the recorder's compiled and Python loops each wrote one."""
    _check_the_scanner()
    root = pathlib.Path(reference_impl.__file__).parent
    found = sorted(
        f"{path.relative_to(root).as_posix()}:{name}"
        for path in root.rglob("*.py")
        for name in _verlet_updates(ast.parse(path.read_text()))
    )
    assert_true(
        found == sorted([_ONE_STEP, _NUMPY_LANES]),
        got=f"velocity-Verlet updates written in {found}",
        should=f"only {_ONE_STEP} (and the numpy lanes {_NUMPY_LANES})",
        claim="tool",
        call="ast scan of reference_impl",
    )
