"""Many impacts of one potential in one call: `solve_impacts` (sweeps and benchmarks).

For a power law U = k q^n / n every result follows from the dimensionless
oscillator integrals of its damping ratio (dq/dx = c x^beta exactly, with c
carrying m, k and v0), so one compiled loop evaluates the Gauss-Jacobi branch
sums of every distinct damping ratio at once (a sweep over speeds at a few
damping ratios costs a few sums plus array arithmetic); the impacts where that rule does not apply (zeta
>= 0.9, n > 4, or the two rule sizes disagree) and every other family go
through `prepare(potential, m)` (`solve_impact` bit for bit) one by one. Results agree with `solve_impact` to round-off.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from reference_impl.errors import HCVInputError, UnsupportedError
from reference_impl.exact._branches import (
    _EPS,
    _GJ_BETA_MIN,
    _GJ_RTOL,
    _GJ_SIZES,
    _GJ_ZETA_MAX,
    _NODE_ULPS,
    _SUM_ULPS_PER_NODE,
    _exponent_splits,
    _fill_rows,
    _jacobi_pair,
    _pow_split,
)
from reference_impl.exact._oscillator import S_END_MAX, ZETA_MAX, VirtualOscillator
from reference_impl.exact._power_kernel import _POWER_ROWS
from reference_impl.exact._route import batch_other, route
from reference_impl.exact._rtol import checked_rtol
from reference_impl.exact._sums import GJ_OK
from reference_impl.exact._validate import _check_exponent, _validated_top
from reference_impl.exact.prepared import prepare
from reference_impl.exact.solve import ImpactSolution
from reference_impl.potentials._checks import positive, real_array
from reference_impl.potentials.base import Potential
from reference_impl.potentials.power import PowerLaw
from reference_impl.theory.damping import _check_zeta

__all__ = ["solve_impacts", "BATCH_MAX"]

# Largest batch accepted: ~8 arrays of this many float64 (~0.6 GB would be 1e7);
# larger sweeps should be chunked by the caller.
BATCH_MAX = 10_000_000
# Rule sizes of the second pass (zeta near 0.9, where (16, 24) do not agree to
# _GJ_RTOL): measured to agree up to zeta = 0.9 for Hertz.
_GJ_SIZES_LARGE = (32, 48)
# Impacts per chunk of `_power_law_fill`; 0: numba's equal shares, one per thread. Chunks
# of 2048 (~0.13 ms each, handed out as threads free up) cost ~1 % on one thread and did
# not measure faster on two (1.76x against 1.82x, load 2.2; the machine was never quiet):
# `python -m benchmarks.bench_batch_phases --fill-chunks` compares them.
_FILL_CHUNK = 0
# Chunks of a loop over the distinct zetas (~3.5 us each; a chunk costs ~2 us to hand
# out): about this many, 4 zetas each for a 50-zeta grid, ~6000 for 1e5 distinct ones.
_ZETA_PARTS = 16
# The oscillator's limits (`_oscillator`), as globals of the compiled check `_count_invalid`.
_ZETA_MAX, _S_END_MAX = ZETA_MAX, S_END_MAX
# Fields of the returned dict, as in `ImpactSolution`.
_FIELDS = (
    "max_penetration",
    "max_force",
    "contact_time",
    "restitution",
    "contact_time_zero_force",
    "restitution_zero_force",
    "quadrature_error",
    "quadrature_error_zero_force",
)


# The compiled functions here run in (or under) parallel loops: error_model "numpy" makes a
# division by zero an inf or NaN (caught by the status tests) instead of an exception, which
# numba cannot carry out of a prange loop: it came back as SystemError on the next call and
# on every later one (issue 36, item 4). The results are the same bits for nonzero divisors.
@numba.njit(cache=True, error_model="numpy")
def _zeta_factor_row(z, f):  # pragma: no cover - compiled
    """``f`` = exp(-zeta s_peak) and the two restitutions (overlap end, zero force) of one
    zeta, the expressions `solve_impact` evaluates (`VirtualOscillator`'s three regimes:
    s_peak = atan2(wd, zeta)/wd, 1 at critical damping, log1p(zeta - 1 + r)/r above it,
    where the body never returns to q = 0: restitution 0), once per zeta instead of per
    impact. (-0.0 and 0.0, one entry of the distinct zetas, give the same bits in each.)"""
    if z < 1.0:
        wd = math.sqrt((1.0 - z) * (1.0 + z))
        sp = math.atan2(wd, z) / wd
        f[1] = math.exp(-math.pi * z / wd)
    elif z == 1.0:
        sp = 1.0
        f[1] = 0.0
    else:
        r = math.sqrt(z - 1.0) * math.sqrt(z + 1.0)
        sp = math.log1p((z - 1.0) + r) / r
        f[1] = 0.0
    f[0] = math.exp(-z * sp)
    f[2] = math.exp(-2.0 * z * sp) if z > 0.0 else 1.0


@numba.njit(cache=True, parallel=True, error_model="numpy")
def _gj_batch(zetas, u, W, beta, zeta_max, rtol, factors, with_factors):  # pragma: no cover
    """Dimensionless branch sums (c = 1, v0 = 1) of every zeta: rise, fall, mid, errors, ok;
    and, with ``with_factors``, ``factors[i]`` = `_zeta_factor_row` of ``zetas[i]``.

    The rows of `_branches._fill_rows` and the one Gauss-Jacobi loop (`_sums.gj_rows`
    bound to `_power_kernel._power_values`, as `power_impact` sums them) at c = 1, with
    no round-off share (``round_rel`` 0: `_power_law_fill` adds it per impact, scaled).
    Each zeta is summed by one thread, in the same order whatever the thread count, so
    the results do not depend on it (bit for bit; test).
    """
    nz = zetas.shape[0]
    out = np.zeros((nz, 6))
    ok = np.zeros(nz, dtype=np.bool_)
    for i in numba.prange(nz):
        z = zetas[i]
        if with_factors:
            _zeta_factor_row(z, factors[i])
        if z >= zeta_max:
            continue
        wd = math.sqrt((1.0 - z) * (1.0 + z))
        sp = math.atan2(wd, z) / wd
        s_end = math.pi / wd
        lz = 2.0 * math.atan2(z, wd) / wd if z > 0.0 else 0.0
        rows = np.empty((3, 5))
        nr = _fill_rows(z, sp, s_end, lz, rows)
        empty = False
        for r in range(nr):
            empty = empty or not rows[r, 4] > 0.0
        if empty:
            continue
        fine = np.empty(3)
        err = np.empty(3)
        # b = 0: the values carry their scale L^(beta+1), as in `power_impact`.
        if _POWER_ROWS(rows, nr, u, W, (z, wd, beta, 1.0), 0.0, rtol, 0.0, fine, err) != GJ_OK:
            continue
        # err = |fine - coarse| exactly (round_rel 0). The batch's own test, relative
        # difference <= rtol, as well: it differs from gj_rows' diff <= rtol |fine| only
        # where a row's sum is subnormal (zeta < ~1e-150: the zero-force row), and keeps
        # those zetas on the one-by-one path, bit for bit the results of before.
        worst = 0.0
        for r in range(nr):
            worst = max(worst, err[r] / abs(fine[r]))
        if not worst <= rtol:
            continue
        ok[i] = True
        if nr == 1:
            out[i, 0], out[i, 1], out[i, 2] = fine[0], fine[0], fine[0]
            out[i, 3], out[i, 4], out[i, 5] = err[0], err[0], err[0]
        else:
            out[i, 0], out[i, 1], out[i, 2] = fine[0], fine[1], fine[1] - fine[2]
            out[i, 3], out[i, 4], out[i, 5] = err[0], err[1], err[1] + err[2]
    return out, ok


def solve_impacts(
    potential: Potential, m: float, v0s, zetas=0.0, *, law=None, rtol: float | None = None
) -> dict[str, np.ndarray]:
    """Solve many impacts of one potential and mass (``reference_impl.solve_batch``).

    Parameters
    ----------
    potential : Potential
        Contact potential U(q).
    m : float
        Mass (kg), > 0.
    v0s : array_like
        Impact speeds (m/s), > 0.
    zetas : array_like
        Damping ratios (as accepted by `solve_impact`), broadcast against ``v0s``.
    law : DampingLaw or dict, optional
        A registered damping law (then ``zetas`` must stay 0). One the harmonic map
        solves (universal, none) runs as its zeta; the others go where their registry
        entry says (`reference_impl.exact._route`): a "general" law's speeds are solved as
        by `reference_impl.exact.general_law.solve_law_impact` (bit for bit; the
        integrations on every core, `_law_batch`), and the arrays are its fields
        (max_penetration, max_force, peak_force, contact_time, restitution,
        contact_time_zero_force, restitution_zero_force, returns_to_q0,
        error_time, error_restitution).
    rtol : float, optional
        Relative error bound asked of each time (0 < rtol <= 0.1; None: full accuracy,
        bit for bit), as `solve_impact`'s. It reaches a general law's integrations and
        the impacts solved one by one (`prepare`); the compiled power-law loop keeps its
        full-accuracy rules (its sums are per distinct zeta, not per impact, so a smaller
        rule saves nothing there); every bound is reported either way.

    Returns
    -------
    dict of numpy.ndarray
        One array per field of `ImpactSolution` (max_penetration, max_force,
        contact_time, restitution, contact_time_zero_force, restitution_zero_force,
        quadrature_error, quadrature_error_zero_force), of the broadcast shape.

    Raises
    ------
    HCVInputError
        Invalid input (the message names the first offending value), or more
        than BATCH_MAX impacts; a damping ratio outside `solve_impact`'s range (above
        ZETA_MAX, or so close below 1 that s_end > S_END_MAX) is refused before any work.
        zeta = 1 and above are solved (critical and overdamped closed forms).
    """
    rtol = checked_rtol(rtol, "solve_impacts")
    if law is not None:
        # The law's registry entry chooses the strategy (`_route`, the one place).
        r = route(law, zetas, "zetas")
        if r.kind != "harmonic map":
            return batch_other(r, potential, m, v0s, BATCH_MAX, rtol)
        zetas = r.zeta
    if not isinstance(potential, Potential):
        raise HCVInputError(f"potential must be a Potential, got {potential!r}")
    m = positive("m", m, "solve_impacts")
    v_in = _float_array("v0s", v0s)
    z_in = _float_array("zetas", zetas)
    try:
        # (np.broadcast_arrays costs ~10 us of serial Python: not for arrays of one shape)
        v, z = (v_in, z_in) if v_in.shape == z_in.shape else np.broadcast_arrays(v_in, z_in)
    except ValueError:
        raise HCVInputError(
            f"solve_impacts: v0s of shape {v_in.shape} and zetas of shape {z_in.shape} do not "
            "broadcast together; give arrays of one shape, or a scalar for either"
        ) from None
    if v.size > BATCH_MAX:
        raise HCVInputError(f"{v.size} impacts requested, more than BATCH_MAX = {BATCH_MAX}")
    shape = v.shape
    v, z = np.ascontiguousarray(v).ravel(), np.ascontiguousarray(z).ravel()
    tiny = float(np.finfo(float).tiny)
    # One compiled pass over every impact; the messages below only when it finds a bad one.
    starts = np.empty(v.size, dtype=np.bool_)
    if _count_invalid(v, z, m, tiny, starts):
        _refuse_invalid(v, z, m, tiny)
    _check_exponent(potential)
    # Every entry is written below: by the kernel, or by the one-by-one loop.
    out = np.empty((len(_FIELDS), v.size))
    beta = 2.0 / potential.leading_exponent - 1.0
    if type(potential) is PowerLaw and beta >= _GJ_BETA_MIN and v.size:
        _validated_top(potential, 0.5 * m * float(v.max()) ** 2)
        rest = _power_law_batch(potential, m, v, z, _unique_zetas(z, starts), beta, out)
    else:
        rest = np.arange(v.size)
    # One impact at a time, checked and planned once (`prepare`: bit for bit solve_impact).
    solver = prepare(potential, m, rtol=rtol) if rest.size else None
    for i in rest:
        sol: ImpactSolution = solver(float(v[i]), float(z[i]))
        for j, key in enumerate(_FIELDS):
            out[j, i] = getattr(sol, key)
    return {key: out[j].reshape(shape) for j, key in enumerate(_FIELDS)}


def _chunk(size: int) -> int:
    """``size`` as the chunk size of a prange loop, on several threads; 0 (numba's equal
    shares) on one, where there is nothing to balance and chunks cost ~1 % of the fill."""
    return size if numba.get_num_threads() > 1 else 0


def _float_array(name: str, values) -> np.ndarray:
    """``values`` as float64 (`real_array`), without its copy when they already are."""
    if isinstance(values, np.ndarray) and values.dtype == np.float64:
        return values
    return real_array(name, values, "solve_impacts")


@numba.njit(cache=True, parallel=True, error_model="numpy")
def _count_invalid(v, z, m, tiny, starts):  # pragma: no cover - compiled
    """How many impacts `_refuse_invalid` would refuse (an integer sum: any thread count),
    and ``starts[i]``: does a run of equal zetas start at impact i (`_unique_zetas`)."""
    bad = 0
    for i in numba.prange(v.shape[0]):
        vi, zi = v[i], z[i]
        energy = 0.5 * m * vi * vi
        ok = math.isfinite(vi) and vi > 0.0 and math.isfinite(energy) and energy >= tiny
        ok = ok and math.isfinite(zi) and 0.0 <= zi <= _ZETA_MAX
        # `VirtualOscillator`'s refusal of zeta just below 1 (s_end beyond S_END_MAX), the
        # same operations: refused here, before any work, not by the one-by-one loop.
        if ok and zi < 1.0:
            ok = not math.pi / math.sqrt((1.0 - zi) * (1.0 + zi)) > _S_END_MAX
        bad += 0 if ok else 1
        starts[i] = i == 0 or zi != z[i - 1]
    return bad


def _refuse_invalid(v: np.ndarray, z: np.ndarray, m: float, tiny: float) -> None:
    """Raise, naming the first offending speed, energy or damping ratio."""
    for vi in v[~(np.isfinite(v) & (v > 0))][:1]:
        raise HCVInputError(f"impact speed v0 must be a finite number > 0, got {vi!r}")
    with np.errstate(all="ignore"):
        energy = 0.5 * m * v * v
    for i in np.flatnonzero(~(np.isfinite(energy) & (energy >= tiny)))[:1]:
        raise HCVInputError(
            f"solve_impacts: kinetic energy m v0^2 / 2 = {float(energy[i])!r} J (m = {m!r}, v0 = "
            f"{float(v[i])!r}) is not a positive float64 in the normal range [{tiny:.3g}, "
            f"{np.finfo(float).max:.3g}] J: rescale the units (e.g. mm, g, ms)"
        )
    for zi in z[~(np.isfinite(z) & (z >= 0))][:1]:
        _check_zeta(zi)
    # zeta above ZETA_MAX or too close below 1: `VirtualOscillator` raises its message.
    with np.errstate(all="ignore"):
        s_end = np.pi / np.sqrt((1.0 - z) * (1.0 + z))
    for zi in z[(z > ZETA_MAX) | ((z < 1.0) & (s_end > S_END_MAX))][:1]:
        VirtualOscillator(1.0, float(zi))


def _unique_zetas(z: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """``np.unique(z)``, from the first value of each run of equal values (``starts``, of
    `_count_invalid`): a sweep grid (each zeta repeated over the speeds) sorts its few
    runs, not every impact. The runs are marked in the parallel pass over the impacts; a
    serial run-by-run loop was ~50 us per 1e5 impacts (0.7 % of a 50 x 2000 grid)."""
    return np.unique(z[starts])


def _power_law_batch(pot: PowerLaw, m, v, z, zu, beta, out) -> np.ndarray:
    """Fill ``out`` for the impacts the compiled Gauss-Jacobi loop accepts; returns the
    indices of the others (for the one-by-one loop). ``zu``: the distinct zetas, sorted."""
    # The dimensionless sums depend on zeta only: one evaluation per distinct zeta, with
    # its factors (`_zeta_factor_row`) in the same parallel loop.
    per_zeta = np.empty((zu.size, 3))
    with numba.parallel_chunksize(_chunk(-(-zu.size // _ZETA_PARTS))):
        sums_u, ok_u = _gj_batch(
            zu, *_jacobi_pair(beta), beta, _GJ_ZETA_MAX, _GJ_RTOL, per_zeta, True
        )
    # Damping ratios near 0.9 need larger rules (longer branches): a second pass.
    nodes_u = np.full(zu.size, float(_GJ_SIZES[1]))
    again = np.flatnonzero(~ok_u & (zu < _GJ_ZETA_MAX))
    if again.size:
        s2, ok2 = _gj_batch(
            zu[again],
            *_jacobi_pair(beta, _GJ_SIZES_LARGE),
            beta,
            _GJ_ZETA_MAX,
            _GJ_RTOL,
            per_zeta,
            False,
        )
        sums_u[again[ok2]], ok_u[again[ok2]] = s2[ok2], True
        nodes_u[again[ok2]] = _GJ_SIZES_LARGE[1]
    n = pot.leading_exponent
    a_hi, a_lo, b_hi, b_lo = _exponent_splits(pot.p, n)
    c0 = (m / pot.k) * _pow_split(0.5 * n * m / pot.k, a_hi, a_lo)
    q_scale = (0.5 * n * m / pot.k) ** (1.0 / n)
    # As `solve_impact` (`solve._check_normal`): a result outside the normal float64
    # range is refused, never returned as 0.0 or a subnormal number.
    tiny = float(np.finfo(float).tiny)
    todo = np.empty(v.size, dtype=np.bool_)
    bad = np.empty(v.size, dtype=np.int8)
    # (rows do not depend on who fills them, nor in which chunks)
    with numba.parallel_chunksize(_chunk(_FILL_CHUNK)):
        left, nbad = _power_law_fill(
            v,
            z,
            zu,
            sums_u,
            per_zeta,
            ok_u,
            nodes_u,
            c0,
            b_hi,
            b_lo,
            q_scale,
            2.0 / n,
            pot.k,
            pot.p,
            tiny,
            out,
            todo,
            bad,
        )
    for j, key in enumerate(("max_penetration", "max_force", "contact_time") if nbad else ()):
        for i in np.flatnonzero(bad & (1 << j))[:1]:
            val = out[_FIELDS.index(key), i]
            raise UnsupportedError(
                f"solve_impacts: {key} = {float(val)!r} is below the normal float64 "
                f"range ({tiny:.3g}) for m = {m!r} kg, v0 = {float(v[i])!r} m/s: rescale the "
                "units (e.g. mm, g, ms) so that it is a normal number"
            )
    return np.flatnonzero(todo) if left else np.arange(0)


@numba.njit(cache=True, parallel=True, error_model="numpy")
def _power_law_fill(
    v,
    z,
    zu,
    sums_u,
    per_zeta,
    ok_u,
    nodes_u,
    c0,
    b_hi,
    b_lo,
    q_scale,
    two_n,
    k,
    p,
    tiny,
    out,
    todo,
    bad,
):  # pragma: no cover - compiled
    """Every field of the impacts whose zeta the Gauss-Jacobi sums accept, into the rows of
    ``out`` (order of _FIELDS), ``todo[i]`` False there and True (row NaN) elsewhere, and
    ``bad[i]`` the bits j of its fields (q_max, U'(q_max), contact time) below ``tiny``.
    One impact per thread step, so the results do not depend on the thread count; the
    two returned counts (impacts left, impacts with a bad bit) are integer sums.

    The index of an impact's zeta in the sorted distinct ``zu`` is found here, by
    bisection (a few compares), not by a serial ``np.unique(..., return_inverse=True)``.
    """
    nv = v.shape[0]
    left = 0
    nbad = 0
    for i in numba.prange(nv):
        zz = z[i]
        iu = np.searchsorted(zu, zz)
        if not ok_u[iu]:
            for f in range(out.shape[0]):
                out[f, i] = np.nan
            todo[i] = True
            bad[i] = 0
            left += 1
            continue
        vi = v[i]
        # c v0^beta with the exponent split as in `_branches.power_law_scale`.
        c = c0 * vi**b_hi * math.exp(b_lo * math.log(vi))
        roundoff = (_SUM_ULPS_PER_NODE * nodes_u[iu] + _NODE_ULPS) * _EPS
        rise, fall, mid = c * sums_u[iu, 0], c * sums_u[iu, 1], c * sums_u[iu, 2]
        e_rise = c * sums_u[iu, 3] + roundoff * rise
        e_fall = c * sums_u[iu, 4] + roundoff * fall
        e_mid = c * sums_u[iu, 5] + roundoff * (abs(fall) + abs(fall - mid))
        x_pk = vi * per_zeta[iu, 0]  # sin(wd s_peak) / wd = 1 at the peak
        # Factored as in `_strategies.peak` (no intermediate underflow for tiny m or v0).
        q_max = q_scale * x_pk**two_n
        f_max = k * q_max**p
        out[0, i] = q_max
        out[1, i] = f_max
        out[2, i] = rise + fall
        out[3, i] = per_zeta[iu, 1]
        out[4, i] = rise + mid
        out[5, i] = per_zeta[iu, 2]
        out[6, i] = e_rise + e_fall
        out[7, i] = e_rise + e_mid
        todo[i] = False
        b = (0 if q_max >= tiny else 1) + (0 if f_max >= tiny else 2)
        b += 0 if rise + fall >= tiny else 4
        bad[i] = b
        nbad += 0 if b == 0 else 1
    return left, nbad
