"""Tool tests of the one velocity-Verlet recorder (`reference_impl.integrators.verlet_path`).

Until issue 16 there were two recording loops, each with a compiled kernel and a Python
fallback: the work-precision study's (`verlet_impact`) and the reference adapter's
(`verlet_trajectory`, `law_trajectory`). Below are frozen copies of the four, as they stood
at commit 2065532, and every output of the one recorder is held to them bit for bit (the
bits of every float: signed zeros and nan included) on impact and two-walls scenes, with
universal, power-law and per-step (`LawDamping`) damping, tension clipping, a blow-up, a
run out of steps, and a potential without a compiled kernel.
"""

from __future__ import annotations

import math

import numba
import numpy as np
import pytest

from reference_impl.adapters.base import ImplementedLaw, PowerDamping
from reference_impl.adapters.law_damping import implemented_law_from_table
from reference_impl.adapters.reference import law_trajectory, verlet_trajectory
from reference_impl.integrators.verlet import SCENE_IMPACT, SCENE_WALLS, _force_energy, kernel_terms
from reference_impl.integrators.verlet_path import verlet_impact
from reference_impl.potentials import PowerLaw
from reference_impl.potentials.expression import Expression
from reference_impl.studies.paper import PAPER_MASS, paper_ellipsoid
from verification.assertions import assert_true


# ----------------------------------------------------------------------------
# The oracle: the two loops before the merge, copied unchanged (compiled without a
# disk cache, so that they never share one with the package's recorder).
# ----------------------------------------------------------------------------
@numba.njit
def _old_path_kernel(fam, par, q_sup, m, c_damp, dt, v0, ys, vs):
    y = 0.0
    v = v0
    F = 0.0
    half = 0.5 * dt / m
    ys[0] = 0.0
    vs[0] = v0
    for n in range(1, ys.shape[0]):
        vh = v + half * F
        y = y + dt * vh
        f = 0.0
        if y > 0.0:
            if not y <= q_sup:
                ys[n] = y
                vs[n] = vh
                return -n
            fe, U = _force_energy(y, fam, par)
            f = -fe
            if c_damp > 0.0 and U > 0.0:
                f -= c_damp * fe / math.sqrt(2.0 * U) * vh
        F = f
        v = vh + half * f
        ys[n] = y
        vs[n] = v
        if y <= 0.0:
            return n
    return 0


def _old_path_python(pot, m, c_damp, dt, v0, ys, vs):
    y, v, F, half = 0.0, v0, 0.0, 0.5 * dt / m
    ys[0], vs[0] = 0.0, v0
    for n in range(1, ys.shape[0]):
        vh = v + half * F
        y = y + dt * vh
        f = 0.0
        if y > 0.0:
            if not y <= pot.q_sup:
                ys[n], vs[n] = y, vh
                return -n
            fe, U = float(pot.dU(y)), float(pot.U(y))
            f = -fe
            if c_damp > 0 and U > 0:
                f -= c_damp * fe / math.sqrt(2.0 * U) * vh
        F = f
        v = vh + half * f
        ys[n], vs[n] = y, v
        if y <= 0.0:
            return n
    return 0


@numba.njit
def _old_traj_kernel(
    fam, par, q_sup, m, c_damp, c_pow, a_pow, clip, dt, v0, n_steps, scene, gap, t, q, v, f
):
    y = 0.0
    vel = v0 if scene == SCENE_IMPACT else -v0
    F = 0.0
    half = 0.5 * dt / m
    t[0] = 0.0
    q[0] = 0.0
    v[0] = vel
    f[0] = 0.0
    touched = False
    for n in range(1, n_steps + 1):
        vh = vel + half * F
        y = y + dt * vh
        if scene == SCENE_IMPACT:
            qq = y
            sgn = -1.0
        elif y > gap:
            qq = y - gap
            sgn = -1.0
        elif y < 0.0:
            qq = -y
            sgn = 1.0
        else:
            qq = max(y - gap, -y)
            sgn = 0.0
        rep = 0.0
        if qq > 0.0:
            if not qq <= q_sup:
                t[n] = n * dt
                q[n] = np.nan
                v[n] = np.nan
                f[n] = np.nan
                return n + 1
            fe, U = _force_energy(qq, fam, par)
            rep = fe
            if c_damp > 0.0 and U > 0.0:
                rep += c_damp * fe / math.sqrt(2.0 * U) * (-sgn * vh)
            if c_pow > 0.0:
                rep += c_pow * qq**a_pow * (-sgn * vh)
            if clip and rep < 0.0:
                rep = 0.0
            touched = True
        F = sgn * rep
        vel = vh + half * F
        t[n] = n * dt
        q[n] = qq
        f[n] = rep
        v[n] = vel
        if scene == SCENE_IMPACT and touched and qq <= 0.0:
            return n + 1
    return n_steps + 1


def _old_traj_python(pot, m, c_damp, c_pow, a_pow, clip, dt, v0, n_steps, scene, gap, c_fun=None):
    t = np.zeros(n_steps + 1)
    q = np.zeros(n_steps + 1)
    v = np.zeros(n_steps + 1)
    f = np.zeros(n_steps + 1)
    y, vel = (0.0, v0) if scene == SCENE_IMPACT else (0.0, -v0)
    v[0] = vel
    F, half, touched = 0.0, 0.5 * dt / m, False
    for n in range(1, n_steps + 1):
        vh = vel + half * F
        y += dt * vh
        if scene == SCENE_IMPACT:
            qq, sgn = y, -1.0
        elif y > gap:
            qq, sgn = y - gap, -1.0
        elif y < 0.0:
            qq, sgn = -y, 1.0
        else:
            qq, sgn = max(y - gap, -y), 0.0
        rep = 0.0
        if qq > 0.0:
            if not qq <= pot.q_sup:
                t[n], q[n], v[n], f[n] = n * dt, np.nan, np.nan, np.nan
                return t[: n + 1], q[: n + 1], v[: n + 1], f[: n + 1]
            arr = np.array([qq])
            fe, U = float(pot._dU(arr)[0]), float(pot._U(arr)[0])
            rep = fe
            if c_damp > 0.0 and U > 0.0:
                rep += c_damp * fe / math.sqrt(2.0 * U) * (-sgn * vh)
            if c_pow > 0.0:
                rep += c_pow * qq**a_pow * (-sgn * vh)
            if c_fun is not None:
                rep += float(c_fun(arr)[0]) * (-sgn * vh)
            if clip and rep < 0.0:
                rep = 0.0
            touched = True
        F = sgn * rep
        vel = vh + half * F
        t[n], q[n], v[n], f[n] = n * dt, qq, vel, rep
        if scene == SCENE_IMPACT and touched and qq <= 0.0:
            return t[: n + 1], q[: n + 1], v[: n + 1], f[: n + 1]
    return t, q, v, f


def _old_trajectory(
    pot, m, v0, dt, n_steps, zeta=0.0, kind="impact", gap=0.0, damping=None, clip=False, c_fun=None
):
    """The old `verlet_trajectory`, and the old `law_trajectory` of a `LawDamping` (c_fun)."""
    scene = SCENE_IMPACT if kind == "impact" else SCENE_WALLS
    c_pow, a_pow = (0.0, 0.0) if damping is None else (float(damping.c), float(damping.exponent))
    args = (float(m), 2.0 * zeta * math.sqrt(m), c_pow, a_pow, bool(clip), float(dt), float(v0))
    args = (*args, int(n_steps), scene, float(gap))
    terms = kernel_terms(pot)
    if c_fun is not None or terms is None:
        return _old_traj_python(pot, *args, c_fun=c_fun)
    t, q, v, f = (np.empty(int(n_steps) + 1) for _ in range(4))
    k = _old_traj_kernel(terms[0], terms[1], float(pot.q_sup), *args, t, q, v, f)
    return t[:k], q[:k], v[:k], f[:k]


def _old_impact(pot, m, v0, zeta, dt, max_steps):
    """The old `verlet_impact`: (y, v, status) before `VerletPath` reads them."""
    ys, vs = np.empty(max_steps + 1), np.empty(max_steps + 1)
    c_damp = 2.0 * zeta * math.sqrt(m)
    terms = kernel_terms(pot)
    if terms is None:
        status = _old_path_python(pot, m, c_damp, dt, v0, ys, vs)
    else:
        status = _old_path_kernel(
            terms[0], terms[1], float(pot.q_sup), float(m), c_damp, float(dt), float(v0), ys, vs
        )
    n = abs(status) if status != 0 else max_steps
    return ys[: n + 1], vs[: n + 1], np.array([status])


# ----------------------------------------------------------------------------
# the cases
# ----------------------------------------------------------------------------
_HERTZ, _M = PowerLaw(1e9, 1.5), 0.0041  # ~5 mm steel sphere: ~450 steps of 2e-7 s
_ELL = paper_ellipsoid()  # q_sup = 2a: v0 = 50 m/s at dt = 2e-4 s passes through the wall
_EXPR = Expression("k*q**2.5/2.5 + c*q**3", k=1e9, c=1e6)  # no compiled kernel: Python loop
_DT = 2e-7

TRAJECTORIES = {
    "impact": dict(pot=_HERTZ, m=_M, v0=1.0, dt=_DT, n_steps=5000),
    "impact-damped": dict(pot=_HERTZ, m=_M, v0=1.0, dt=_DT, n_steps=5000, zeta=0.3),
    "impact-power": dict(
        pot=_HERTZ, m=_M, v0=1.0, dt=_DT, n_steps=5000, damping=PowerDamping(60.0, 0.0)
    ),
    "impact-power-clip": dict(
        pot=_HERTZ, m=_M, v0=1.0, dt=_DT, n_steps=5000, damping=PowerDamping(60.0, 0.0), clip=True
    ),
    "impact-all-damping-clip": dict(
        pot=_HERTZ,
        m=_M,
        v0=1.0,
        dt=_DT,
        n_steps=5000,
        zeta=0.1,
        damping=PowerDamping(3e3, 0.25),
        clip=True,
    ),
    "impact-out-of-steps": dict(pot=_HERTZ, m=_M, v0=1.0, dt=_DT, n_steps=50, zeta=0.3),
    "two-walls": dict(pot=_HERTZ, m=_M, v0=1.0, dt=_DT, n_steps=3000, kind="two-walls", gap=1e-5),
    "two-walls-damped-gap0": dict(
        pot=_HERTZ, m=_M, v0=1.0, dt=_DT, n_steps=3000, zeta=0.1, kind="two-walls"
    ),
    "two-walls-power-clip": dict(
        pot=_HERTZ,
        m=_M,
        v0=1.0,
        dt=_DT,
        n_steps=3000,
        kind="two-walls",
        gap=1e-5,
        damping=PowerDamping(60.0, 0.5),
        clip=True,
    ),
    "impact-blown": dict(pot=_ELL, m=PAPER_MASS, v0=50.0, dt=2e-4, n_steps=5000),
    "two-walls-blown": dict(
        pot=_ELL, m=PAPER_MASS, v0=50.0, dt=2e-4, n_steps=5000, kind="two-walls", gap=1e-5
    ),
    "ellipsoid-damped": dict(pot=_ELL, m=PAPER_MASS, v0=0.99, dt=2e-6, n_steps=20000, zeta=0.2),
    "python-impact-damped": dict(pot=_EXPR, m=_M, v0=1.0, dt=_DT, n_steps=5000, zeta=0.3),
    "python-power-clip": dict(
        pot=_EXPR, m=_M, v0=1.0, dt=_DT, n_steps=5000, damping=PowerDamping(60.0, 0.0), clip=True
    ),
    "python-two-walls": dict(
        pot=_EXPR, m=_M, v0=1.0, dt=_DT, n_steps=1500, zeta=0.05, kind="two-walls", gap=1e-5
    ),
}

IMPACTS = {
    "hertz": (_HERTZ, _M, 1.0, 0.0, _DT, 5000),
    "hertz-damped": (_HERTZ, _M, 1.0, 0.2, _DT, 5000),
    "ellipsoid": (_ELL, PAPER_MASS, 0.99, 0.0, 2e-6, 20000),
    "blown": (_ELL, PAPER_MASS, 50.0, 0.0, 2e-4, 5000),
    "out-of-steps": (_HERTZ, _M, 1.0, 0.2, _DT, 40),
    "python-damped": (_EXPR, _M, 1.0, 0.3, _DT, 5000),
}


def _same_bits(got, old, call):
    got = [np.asarray(a, dtype=float) for a in got]
    old = [np.asarray(a, dtype=float) for a in old]
    same = len(got) == len(old) and all(
        g.shape == o.shape and np.array_equal(g.view(np.int64), o.view(np.int64))
        for g, o in zip(got, old, strict=False)
    )
    diff = "" if same else f"shapes {[g.shape for g in got]} vs {[o.shape for o in old]}"
    assert_true(
        same,
        got=f"outputs differing from the old loop {diff}",
        should="the same bits",
        claim="tool",
        call=call,
    )


@pytest.mark.parametrize("name", sorted(TRAJECTORIES))
def test_verlet_trajectory_is_the_old_loop_bit_for_bit(name):
    case = TRAJECTORIES[name]
    _same_bits(verlet_trajectory(**case), _old_trajectory(**case), f"verlet_trajectory[{name}]")


@pytest.mark.parametrize("name", sorted(IMPACTS))
def test_verlet_impact_is_the_old_loop_bit_for_bit(name):
    args = IMPACTS[name]
    path = verlet_impact(*args)
    ys, vs, status = _old_impact(*args)
    got_status = path.steps * (1 if path.separated else -1 if path.blown else 0)
    _same_bits((path.y, path.v, [got_status]), (ys, vs, status), f"verlet_impact[{name}]")


@pytest.mark.parametrize(
    "table, clip",
    [({"law": "viscoelastic", "A": 1e-6}, False), ({"law": "linear", "c": 2.0}, True)],
)
def test_law_trajectory_of_a_law_damping_is_the_old_loop_bit_for_bit(table, clip):
    law = implemented_law_from_table(_HERTZ, _M, table)
    law = ImplementedLaw(_HERTZ, _M, None, law.C, clip)
    old = _old_trajectory(_HERTZ, _M, 1.0, _DT, 5000, clip=clip, c_fun=law.C)
    _same_bits(law_trajectory(law, 1.0, _DT, 5000), old, f"law_trajectory({table}, clip={clip})")
