"""numbalsoda's dop853 as a peer (issue 38, goal 1): the regularised equations, events by re-integration.

numbalsoda (0.3.4; its source build needs a Fortran compiler: ``apt-get install
gfortran``) wraps a C++ DOP853 callable from numba with a C right-hand side. It is given
its best formulation here, the Sundman-regularised system of `benchmarks.peer_sundman`
(polynomial laws only: `case_factory` gives None where N b or N e is not an integer),
whose right-hand side is a `numba.cfunc` reading the scaled polynomial tables from its
data array.

numbalsoda reports the solution at requested values of s only: no events, no dense
output, no count of evaluations. So, as a user of it must, each impact is sampled at
`SAMPLES` points of s per `S_CHUNK`, the first sign change of each event function
between samples is bracketed, and its root is refined by integrating again from the
sample before it (Newton for rho and W, whose derivatives are the right-hand side;
Illinois for F / U' and dF/ds), to a few ulps of s. The outputs are those of
`benchmarks._dop853_core.OUT_FIELDS` (nfev: the number of numbalsoda calls, its only
count).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numbalsoda import dop853, lsoda_sig

from . import peer_dop853 as plain
from . import peer_sundman as sundman
from ._dop853_core import OUT_FIELDS

__all__ = ["S_CHUNK", "SAMPLES", "case_factory", "solve_numbalsoda"]

# Samples per chunk of s, and the chunk: a Hertz contact takes s ~ 2-4 (a few chunks;
# more for a creeping return, up to peer_sundman.S_BOUND). Past the exit (rho < 0) the
# polynomial right-hand side runs away (dW/ds ~ -rho^4 for N = 2 on Hertz: a blow-up
# within s ~ 1.5, measured), so a chunk must not reach far beyond it: 1.
S_CHUNK = 1.0
SAMPLES = 9
# Root refinement: iterations (Newton converges in a few; Illinois in < 2 x 53 halvings).
_ROOT_ITER = 120
_MXSTEP = 100_000


@numba.njit(cache=True, error_model="numpy")
def _tables(rho, p):  # pragma: no cover - compiled
    """(f, c, f', c', N rho^(N-1)) of the data array p = [N, nf, nc, (coef, degree)...]."""
    N = int(p[0])
    nf = int(p[1])
    nc = int(p[2])
    f = df = c = dc = 0.0
    for i in range(nf):
        co, d = p[3 + 2 * i], int(p[4 + 2 * i])
        f += co * rho**d
        if d > 0:
            df += co * d * rho ** (d - 1)
    for j in range(nc):
        co, d = p[3 + 2 * nf + 2 * j], int(p[4 + 2 * nf + 2 * j])
        c += co * rho**d
        if d > 0:
            dc += co * d * rho ** (d - 1)
    return f, c, df, dc, N * rho ** (N - 1)


@numba.cfunc(lsoda_sig)
def _rhs(s, u, du, p):  # pragma: no cover - compiled
    f, c, _df, _dc, dts = _tables(u[0], p)
    du[0] = u[1]
    du[1] = -dts * (c * u[1] + f)
    du[2] = dts


_RHS = _rhs.address


@numba.njit(cache=True, error_model="numpy")
def _g(kind, y, p, universal):  # pragma: no cover - compiled
    """The event functions of `benchmarks.peer_sundman._event` (0: rho, 1: W, 2: F / U',
    3: dF/ds, -1 for the universal law)."""
    if kind == 0:
        return y[0]
    if kind == 1:
        return y[1]
    if kind == 3 and universal:
        return -1.0
    f, c, df, dc, dts = _tables(y[0], p)
    w = y[1]
    if kind == 2:
        return (f + c * w) / f
    return w * (df + dc * w) - c * dts * (c * w + f)


@numba.njit(error_model="numpy")
def _advance(y, s0, s1, p, rtol):  # pragma: no cover - compiled
    """The state at s1 integrated from y at s0 (one numbalsoda call)."""
    if s1 == s0:
        return y.copy()
    usol, _ok = dop853(_RHS, y, np.array([s0, s1]), p, rtol, rtol, _MXSTEP)
    return usol[1].copy()


@numba.njit(error_model="numpy")
def _root(kind, y0, s0, s1, g0, g1, p, rtol, universal):  # pragma: no cover - compiled
    """(s, state, calls) at the root of event ``kind`` in (s0, s1], integrating from y0 at
    s0: Newton for rho and W (their derivatives are the right-hand side), Illinois for the
    others, both kept inside the bracket."""
    a, b, ga, gb = s0, s1, g0, g1
    side = 0
    calls = 0
    x, y, g = s0, y0.copy(), g0
    for _ in range(_ROOT_ITER):
        if kind <= 1:
            f, c, _df, _dc, dts = _tables(y[0], p)
            der = y[1] if kind == 0 else -dts * (c * y[1] + f)
            xn = x - g / der if der != 0.0 else 0.5 * (a + b)
        else:
            xn = (a * gb - b * ga) / (gb - ga)
        if not (a < xn < b):
            xn = 0.5 * (a + b)
        y = _advance(y0, s0, xn, p, rtol)
        calls += 1
        g = _g(kind, y, p, universal)
        step = abs(xn - x)
        x = xn
        if g > 0.0:
            a, ga = x, g
            if side == 1:
                gb *= 0.5
            side = 1
        else:
            b, gb = x, g
            if side == -1:
                ga *= 0.5
            side = -1
        if b - a <= 4e-16 * b or g == 0.0 or (kind <= 1 and step <= 4e-16 * x):
            break
    return x, y, calls


@numba.njit(error_model="numpy")
def solve_numbalsoda(p, universal, f_onset, g3_onset, L, v0, Fs, rtol, out):
    """One impact on the regularised system (`benchmarks.peer_sundman`'s scaling).

    Parameters
    ----------
    p : ndarray
        The data array [N, nf, nc, (coef, degree) of f ..., of c ...] (scaled tables).
    universal : bool
        The universal law (no peak-force event).
    f_onset, g3_onset : float
        The force (N) and the sign of dF/dt just after onset (`peer_dop853`'s).
    L, v0, Fs : float
        Length (m), speed (m/s) and force (N) scales.
    rtol : float
        numbalsoda's rtol; atol = rtol on the scaled state.
    out : ndarray
        Receives `OUT_FIELDS` (physical units); returned.
    """  # pragma: no cover - compiled
    N = int(p[0])
    for i in range(7):
        out[i] = np.nan
    out[6] = f_onset
    y = np.array([0.0, 1.0, 0.0])
    s = 0.0
    calls = 0
    g_old = np.array([0.0, 1.0, np.inf, g3_onset])
    g_new = np.empty(4)
    found = np.zeros(4, dtype=np.bool_)
    status = 1.0
    while s < sundman.S_BOUND and status != 0.0:
        grid = np.linspace(s, s + S_CHUNK, SAMPLES)
        usol, ok = dop853(_RHS, y, grid, p, rtol, rtol, _MXSTEP)
        calls += 1
        if not ok:
            status = 2.0
            break
        g_old[0] = 1.0  # rho > 0 inside (0 at onset only)
        for i in range(1, SAMPLES):
            yi = usol[i]
            for kind in range(4):
                g_new[kind] = _g(kind, yi, p, universal)
            if g_new[0] <= 0.0:
                # The end in this interval: the other events read up to it.
                se, ye, c = _root(0, usol[i - 1], grid[i - 1], grid[i], g_old[0], g_new[0], p, rtol, universal)  # fmt: skip
                # Just before the end (1e-8 of the interval), where F / U' and dF/ds are
                # still defined (an event closer to the end counts as the end).
                hi = se - 1e-8 * (se - grid[i - 1])
                yh = _advance(usol[i - 1], grid[i - 1], hi, p, rtol)
                calls += c + 1
                for kind in range(1, 4):
                    g_new[kind] = _g(kind, yh, p, universal) if yh[0] > 0.0 else 1.0
            else:
                hi = grid[i]
            for kind in (1, 3, 2):
                if g_old[kind] > 0.0 and g_new[kind] <= 0.0 and not (kind != 3 and found[kind]):
                    sk, yk, c = _root(kind, usol[i - 1], grid[i - 1], hi, g_old[kind], g_new[kind], p, rtol, universal)  # fmt: skip
                    calls += c
                    f, cc, _df, _dc, _dts = _tables(max(yk[0], 0.0), p)
                    if kind == 1:
                        out[4], out[5] = L * max(yk[0], 0.0) ** N, Fs * f
                    elif kind == 3:
                        out[6] = max(out[6], Fs * (f + cc * yk[1]))
                    else:
                        out[2], out[3] = yk[2] * L / v0, v0 * yk[1]
                    found[kind] = True
            if g_new[0] <= 0.0:
                out[0], out[1] = ye[2] * L / v0, v0 * ye[1]
                if not found[2]:
                    out[2], out[3] = out[0], out[1]
                status = 0.0
                break
            for kind in range(4):
                g_old[kind] = g_new[kind]
        s = grid[-1]
        y = usol[-1].copy()
    out[7] = calls
    out[8] = status
    return out


def case_factory(el, pot, m):
    """``case(v0, law) -> call(rtol) -> out`` as `benchmarks._peers`; None for a law whose
    regularised right-hand side is not a polynomial (numbalsoda gets integer degrees only)."""

    def case(v0, law):
        da, zeta = plain.damping_table(pot, law)
        n = sundman.sundman_n(el, da, zeta)
        if n == 0:
            return None
        L = pot.turning_point(0.5 * m * v0 * v0, check=False)
        Fs, Cs = m * v0 * v0 / L, L / (m * v0)
        f_rows = [(a * L**b / Fs, n * b) for _k, a, b, _c, _d in el]
        c_rows = [(Cs * c * L**e, n * e) for c, e in da]
        if zeta > 0.0:
            if len(el) != 1:
                return None  # U' / sqrt(2 U) of a sum: no polynomial
            a, b = el[0, 1], el[0, 2]
            cu = 2.0 * zeta * math.sqrt(m) * math.sqrt(0.5 * a * (b + 1.0))
            c_rows.append((Cs * cu * L ** (0.5 * (b - 1.0)), 0.5 * n * (b - 1.0)))
        rows = f_rows + c_rows
        if any(abs(d - round(d)) > 1e-12 for _c, d in rows):
            return None
        p = np.array(
            [n, len(f_rows), len(c_rows)] + [x for co, d in rows for x in (co, float(round(d)))]
        )
        f0, df0, _du = plain._force(plain._Q_ONSET, v0, m, zeta, el, da)
        g3 = -1.0 if zeta != 0.0 else df0
        out = np.empty(len(OUT_FIELDS))

        def call(rtol):
            return solve_numbalsoda(p, zeta != 0.0, f0, g3, L, v0, Fs, rtol, out)

        return call

    return case
