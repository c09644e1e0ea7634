"""Velocity-Verlet lane engine: many (time step, impact speed, phase) runs at once.

Each *lane* is one run of velocity Verlet (central difference) of one particle
of mass m against one or two contacts. The engine integrates many lanes in
one call and stops a lane as soon as it has blown up or finished; the
critical-step searches of `reference_impl.stability.search` are built on it.

Conventions (decided here, used everywhere in the package)
-----------------------------------------------------------
* Variant: kick-drift-kick velocity Verlet with the force at the new position,

      v_{n+1/2} = v_n + dt/2 * F(y_n) / m
      y_{n+1}   = y_n + dt * v_{n+1/2}
      v_{n+1}   = v_{n+1/2} + dt/2 * F(y_{n+1}) / m,

  algebraically identical to the central difference y_{n+1} - 2 y_n + y_{n-1}
  = dt^2 F(y_n) / m. With damping the dashpot force at y_{n+1} uses the
  half-step velocity v_{n+1/2} (the usual explicit DEM treatment).
* Energy: the physical energy E_n = m v_n^2 / 2 + U(q_n) at the synchronised
  integer steps (position and velocity of the same step n).
* Geometry: ``y`` is the particle position (m). Scene IMPACT has one wall: the
  overlap is q = y where y > 0, free flight where y <= 0. Scene WALLS has two
  walls: overlap q = y - gap where y > gap (force towards -y) and q = -y where
  y < 0 (force towards +y); the two-sided oscillator U(|q|) is WALLS with
  gap = 0. The potential is evaluated only at overlaps q > 0, never at q <= 0.
* Blow-up: a lane stops as *blown* when q exceeds the potential's domain
  q_sup (e.g. 2a for the ellipsoid: the body has passed through the wall) or a
  state becomes non-finite, and as *unstable* when E_n exceeds its energy limit.
* Confirmation: a lane given ``e_confirm > e_limit`` does not stop at its first
  crossing of ``e_limit``; it runs on up to ``confirm_steps`` steps and stops as
  over-limit only if E_n also exceeds ``e_confirm``, else as *bounded* (a large
  but saturating excursion, e.g. the linear spring just below 2/omega, whose
  orbit peaks at E_0 / (1 - (omega dt / 2)^2)). Bounded lanes are not failures.
* Interrupts: the compiled kernel returns to Python every ~4e6 lane-steps and
  is resumed from saved per-lane state, so Ctrl-C (KeyboardInterrupt) gets
  through within a fraction of a second even for lanes of 1e8 steps.

Potentials with a term table (`reference_impl.potentials._terms`: PowerLaw,
Ellipsoid, Sphere, `SaturatingForce`, a user `Expression` that is a sum of
constants times powers of q, and sums of them) run in one numba kernel that
receives the terms' parameters as arrays (`kernel_terms`). Any other
`Expression` runs in the same kernel with its sympy U', U compiled in
(`_expression_kernel`, once per distinct expression and process) when the batch
is long enough to repay the compile; any other `Potential`, or such an expression
in a short batch, runs in a numpy fallback that advances all lanes together, one
step per vectorised call of ``Potential._dU``/``_U``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from reference_impl.errors import HCVInputError
from reference_impl.integrators.verlet_expression import _expression_kernel, _worth_compiling
from reference_impl.integrators.verlet_kernel import (
    _BLOCK,
    _CHUNK_LANE_STEPS,
    _N_PAR,
    _PENDING,
    _ST_BLOWN,
    _ST_BOUNDED,
    _ST_COMPLETED,
    _ST_END_GAIN,
    _ST_NO_SEPARATION,
    _ST_OVER_LIMIT,
    _ST_SEPARATED,
    _ST_SKIPPED,
    SCENE_IMPACT,
    SCENE_WALLS,
    STATUS_NAMES,
    SaturatingForce,
    _kernel,
    kernel_terms,
)
from reference_impl.integrators.verlet_kernel import (
    _force_energy as _force_energy,  # re-export (adapters, report)
)
from reference_impl.potentials.base import Potential

__all__ = [
    "SCENE_IMPACT",
    "SCENE_WALLS",
    "STATUS_NAMES",
    "LaneBatch",
    "LaneResult",
    "SaturatingForce",
    "kernel_terms",
    "run_lanes",
]


# ----------------------------------------------------------------------------
# public interface
# ----------------------------------------------------------------------------
def _lane_array(x, n: int, dtype) -> np.ndarray:
    """``x`` broadcast to ``n`` lanes as a writable C-contiguous array of ``dtype``.

    Writable always, a copy where needed: numba compiles the lane kernel once per pattern
    of read-only and writable arguments (~3-20 s each on a cold cache), and
    ``ascontiguousarray(broadcast_to(x))`` was read-only for an array of n lanes but a
    writable copy for a scalar, so the suite's callers made 7 kernels of one."""
    return np.require(np.broadcast_to(np.asarray(x, dtype=dtype), (n,)), dtype, ["C", "W"])


@dataclass
class LaneBatch:
    """The lanes of one engine call (all arrays have one entry per lane).

    Attributes
    ----------
    dt : ndarray
        Time step (s).
    y0, v0 : ndarray
        Start position (m, see the module conventions) and velocity (m/s).
    e_limit : ndarray
        Energy (J) above which the lane stops as over-limit; ``inf`` for none.
    max_steps : ndarray of int
        Step budget of the lane (>= 1).
    gap : ndarray or float
        Free-flight gap between the walls of `SCENE_WALLS` (m, >= 0; 0 is the
        two-sided oscillator U(|q|)); ignored by `SCENE_IMPACT`. Default 0.
    e_final : ndarray or float
        Energy (J) that the last E_n of a lane which ran to its end (or
        separated) must not exceed, else the lane ends as end-over-limit
        (the single-impact criterion); default ``inf`` (none).
    group : ndarray of int, optional
        Group index (>= 0) for ``skip_after_fail``; default all 0.
    e_confirm : ndarray or float, optional
        Confirmation energy (J, >= e_limit); default ``e_limit`` (the lane stops
        at its first crossing of e_limit). See the module conventions.
    confirm_steps : ndarray of int, optional
        Step budget (>= max_steps) of a lane that crossed e_limit while being
        confirmed; default ``max_steps``.
    """

    dt: np.ndarray
    y0: np.ndarray
    v0: np.ndarray
    e_limit: np.ndarray
    max_steps: np.ndarray
    gap: np.ndarray | float = 0.0
    e_final: np.ndarray | float = math.inf
    group: np.ndarray | None = None
    e_confirm: np.ndarray | float | None = None
    confirm_steps: np.ndarray | int | None = None

    def __post_init__(self):
        n = np.asarray(self.dt).shape[0]
        self.dt = _lane_array(self.dt, n, np.float64)
        self.y0 = _lane_array(self.y0, n, np.float64)
        self.v0 = _lane_array(self.v0, n, np.float64)
        self.gap = _lane_array(self.gap, n, np.float64)
        self.e_limit = _lane_array(self.e_limit, n, np.float64)
        self.e_final = _lane_array(self.e_final, n, np.float64)
        self.max_steps = _lane_array(self.max_steps, n, np.int64)
        g = np.zeros(n, dtype=np.int64) if self.group is None else self.group
        self.group = _lane_array(g, n, np.int64)
        ec = self.e_limit if self.e_confirm is None else self.e_confirm
        self.e_confirm = _lane_array(ec, n, np.float64)
        cs = self.max_steps if self.confirm_steps is None else self.confirm_steps
        self.confirm_steps = _lane_array(cs, n, np.int64)
        if np.any(~(self.dt > 0)) or np.any(~np.isfinite(self.dt)):
            raise HCVInputError("every lane time step must be finite and > 0")
        if np.any(self.max_steps < 1):
            raise HCVInputError("every lane needs max_steps >= 1")
        if np.any(~(self.gap >= 0)) or np.any(~np.isfinite(self.gap)):
            raise HCVInputError("every lane gap must be finite and >= 0")
        if np.any(~(self.e_confirm >= self.e_limit)):
            raise HCVInputError("every lane needs e_confirm >= e_limit")
        if np.any(self.confirm_steps < self.max_steps):
            raise HCVInputError("every lane needs confirm_steps >= max_steps")

    def __len__(self) -> int:
        return self.dt.shape[0]


@dataclass
class LaneResult:
    """Per-lane outcome of `run_lanes`.

    Attributes
    ----------
    status : ndarray of int
        Index into `STATUS_NAMES`.
    steps : ndarray of int
        Steps taken before the lane stopped.
    e_max : ndarray
        Largest E_n seen (J), including E_0.
    e_end : ndarray
        E_n at the last step taken (J); for a separated impact the rebound energy.
    hist : ndarray, shape (n_lanes, n_checkpoints)
        max_{k <= c} E_k / E_0 at each checkpoint step c; NaN if not reached.
    engine : str
        "numba" or "numpy".
    """

    status: np.ndarray
    steps: np.ndarray
    e_max: np.ndarray
    e_end: np.ndarray
    hist: np.ndarray
    engine: str

    @property
    def failed(self) -> np.ndarray:
        """True for lanes that went over an energy limit or blew up."""
        return np.isin(self.status, (_ST_OVER_LIMIT, _ST_BLOWN, _ST_END_GAIN))

    @property
    def bounded(self) -> np.ndarray:
        """True for lanes that crossed e_limit but stayed below e_confirm (not failures)."""
        return self.status == _ST_BOUNDED

    @property
    def ran(self) -> np.ndarray:
        """True for lanes that were integrated (not skipped)."""
        return self.status != _ST_SKIPPED


def run_lanes(
    pot: Potential,
    m: float,
    scene: int,
    batch: LaneBatch,
    *,
    zeta: float = 0.0,
    checkpoints=None,
    skip_after_fail: bool = False,
    engine: str = "auto",
    block: int = _BLOCK,
) -> LaneResult:
    """Run velocity Verlet on every lane of ``batch``.

    Parameters
    ----------
    pot : Potential
        Contact potential U(q) (J, q in m).
    m : float
        Particle mass (kg).
    scene : int
        `SCENE_IMPACT` (one wall at y = 0) or `SCENE_WALLS` (walls at y = 0 and
        y = gap of each lane).
    batch : LaneBatch
        The lanes.
    zeta : float
        Damping ratio of the universal law C(q) = 2 zeta sqrt(m) U'/sqrt(2U)
        (dimensionless, >= 0); 0 for the conservative contact.
    checkpoints : array_like of int, optional
        Increasing step numbers at which max E / E_0 is recorded.
    skip_after_fail : bool
        Process lanes by increasing dt within each group and skip those at or
        above a dt that already failed (searches need only the first failure).
    engine : {"auto", "numba", "numpy"}
        "auto" uses numba for a potential with a term table, and for another
        `Expression` when the batch is long enough to repay compiling its
        kernel; numpy otherwise. "numba" compiles such an Expression's kernel
        whatever the batch.
    block : int
        Lanes the numba kernel advances in lockstep (results do not depend on it).

    Returns
    -------
    LaneResult
    """
    if scene not in (SCENE_IMPACT, SCENE_WALLS):
        raise HCVInputError(f"unknown scene code {scene!r}")
    if not (math.isfinite(zeta) and zeta >= 0):
        raise HCVInputError(f"damping ratio zeta must be finite and >= 0, got {zeta!r}")
    cps = np.ascontiguousarray(
        np.unique(np.asarray([] if checkpoints is None else checkpoints, dtype=np.int64))
    )
    if engine not in ("auto", "numba", "numpy"):
        raise HCVInputError(f"engine must be 'auto', 'numba' or 'numpy', got {engine!r}")
    terms, kern = kernel_terms(pot), _kernel
    if terms is None and (engine == "numba" or (engine == "auto" and _worth_compiling(batch))):
        kern = _expression_kernel(pot)
        if kern is not None:
            terms = (np.zeros(1, dtype=np.int64), np.zeros((1, _N_PAR)))
    if engine == "auto":
        engine = "numpy" if terms is None else "numba"
    if engine == "numba" and terms is None:
        raise HCVInputError(f"no numba kernel for {pot!r}; use engine='numpy'")
    n = len(batch)
    order = np.lexsort((batch.dt, batch.group)).astype(np.int64)
    c_damp = 2.0 * zeta * math.sqrt(m)
    q_sup = float(pot.q_sup)
    if engine == "numba":
        st = np.zeros(n, dtype=np.int64)
        steps = np.zeros(n, dtype=np.int64)
        emax = np.full(n, np.nan)
        eend = np.full(n, np.nan)
        hist = np.full((n, cps.shape[0]), np.nan)
        st[:] = _PENDING
        fail_dt = np.full(int(batch.group.max()) + 1 if n else 1, np.inf)
        fs = np.zeros((n, 6))
        istate = np.zeros((n, 4), dtype=np.int64)
        b = 0
        while b < n:  # each call returns within _CHUNK_LANE_STEPS, so Ctrl-C gets through
            b = kern(
                terms[0],
                terms[1],
                q_sup,
                float(m),
                int(scene),
                c_damp,
                batch.dt,
                batch.y0,
                batch.v0,
                batch.gap,
                batch.e_limit,
                batch.e_confirm,
                batch.confirm_steps,
                batch.e_final,
                batch.max_steps,
                batch.group,
                order,
                bool(skip_after_fail),
                cps,
                int(block),
                b,
                _CHUNK_LANE_STEPS,
                fail_dt,
                fs,
                istate,
                st,
                steps,
                emax,
                eend,
                hist,
            )
        return LaneResult(st, steps, emax, eend, hist, "numba")
    return _run_numpy(pot, float(m), scene, batch, c_damp, q_sup, cps, skip_after_fail)


# The numpy engine is the one twin of the step (`verlet_kernel._kdk`) kept, for potentials
# without a compiled force, because it measures faster for its use: the step run as Python
# (the lane kernel rebound to the Potential's force, `reference_impl._jit.rebind`) costs
# 70 us a lane-step for an Expression; this engine 34, 8.8, 0.70 and 0.24 us at 4, 16, 256
# and 1024 lanes (2x to 290x faster; interleaved, CPU time, load 5 on 2 cores). Only a
# single lane runs faster as Python (71 against 136 us), and searches run many lanes.

# How often (in steps) the numpy engine compacts its active lanes and applies
# skip_after_fail: compaction costs a few array copies, so not every step.
_NUMPY_COMPACT_EVERY = 32


def _numpy_force(pot, y, scene, gap, q_sup):
    """Signed elastic force, U'(q), U(q) and blown mask for positions y (numpy)."""
    if scene == SCENE_IMPACT:
        q, sgn = y, -1.0
    else:
        right = y > gap
        q = np.where(right, y - gap, -y)
        sgn = np.where(right, -1.0, 1.0)
    with np.errstate(invalid="ignore"):
        contact = q > 0
        blown = ~np.isfinite(q) | (contact & ~(q <= q_sup))
    ok = contact & ~blown
    fe = np.zeros_like(y)
    U = np.zeros_like(y)
    if np.any(ok):
        qc = q[ok]
        fe[ok] = pot._dU(qc)
        U[ok] = pot._U(qc)
    return sgn * fe, fe, U, ok, blown


def _run_numpy(pot, m, scene, batch, c_damp, q_sup, cps, skip_after_fail):
    n = len(batch)
    st = np.full(n, _ST_COMPLETED, dtype=np.int64)
    steps = np.zeros(n, dtype=np.int64)
    emax = np.full(n, np.nan)
    eend = np.full(n, np.nan)
    hist = np.full((n, cps.shape[0]), np.nan)
    idx = np.arange(n)
    h = batch.dt.copy()
    y = batch.y0.copy()
    v = batch.v0.copy()
    gap = batch.gap.copy()
    F, _, U, contact, _ = _numpy_force(pot, y, scene, gap, q_sup)
    E0 = 0.5 * m * v * v + U
    em = E0.copy()
    E = E0.copy()
    touched = contact.copy()
    lim = batch.e_limit.copy()
    econf = batch.e_confirm.copy()
    nconf = batch.confirm_steps.copy()
    tripped = np.zeros(n, dtype=bool)
    efin = batch.e_final.copy()
    nmax = batch.max_steps.copy()
    grp = batch.group.copy()
    active = np.ones(n, dtype=bool)
    fail_dt = np.full(int(grp.max()) + 1 if n else 1, np.inf)
    step = 0
    while idx.size:
        step += 1
        vh = v + 0.5 * h / m * F
        y = y + h * vh
        F, fe, U, contact, blown = _numpy_force(pot, y, scene, gap, q_sup)
        if c_damp > 0:
            with np.errstate(divide="ignore", invalid="ignore"):
                damp = np.where(contact & (U > 0), c_damp * fe / np.sqrt(2 * U), 0.0)
            F = F - damp * vh
        v = vh + 0.5 * h / m * F
        E = 0.5 * m * v * v + U
        touched |= contact
        blown |= ~np.isfinite(E)
        # Blown lanes keep the energy of their last finite step, as in the kernel.
        em = np.where(blown, em, np.maximum(em, E))
        for j in np.nonzero(cps == step)[0]:
            hist[idx, j] = em / E0
        over = ~blown & (E > lim)
        trip = over & ~tripped & (econf > lim)  # first crossing: follow on to the confirmation
        if np.any(trip):
            tripped |= trip
            lim = np.where(trip, econf, lim)
            nmax = np.where(trip, nconf, nmax)
            over = ~blown & (E > lim)
        sep = ~blown & ~over & touched & (y <= 0) if scene == SCENE_IMPACT else np.zeros_like(over)
        out_of_steps = step >= nmax
        done = blown | over | sep | out_of_steps
        code = np.where(
            blown,
            _ST_BLOWN,
            np.where(
                over,
                _ST_OVER_LIMIT,
                np.where(
                    sep,
                    _ST_SEPARATED,
                    np.where(
                        tripped,
                        _ST_BOUNDED,
                        _ST_NO_SEPARATION if scene == SCENE_IMPACT else _ST_COMPLETED,
                    ),
                ),
            ),
        )
        end_gain = ~blown & ~over & ~(tripped & out_of_steps & ~sep) & (E > efin)
        code = np.where(end_gain, _ST_END_GAIN, code)
        if np.any(done):
            d = idx[done]
            st[d] = code[done]
            steps[d] = step
            emax[d] = em[done]
            eend[d] = np.where(blown[done], np.nan, E[done])
            failed = done & (blown | over | end_gain)
            if np.any(failed):
                np.minimum.at(fail_dt, grp[failed], h[failed])
            active[done] = False
        if skip_after_fail and (np.any(done) or step % _NUMPY_COMPACT_EVERY == 0):
            late = active & (h >= fail_dt[grp])
            st[idx[late]] = _ST_SKIPPED
            active &= ~late
        if not np.all(active):
            keep = active
            idx, h, y, v, gap, F, E0, em, touched, lim, efin, nmax, grp, econf, nconf, tripped = (
                a[keep]
                for a in (
                    idx,
                    h,
                    y,
                    v,
                    gap,
                    F,
                    E0,
                    em,
                    touched,
                    lim,
                    efin,
                    nmax,
                    grp,
                    econf,
                    nconf,
                    tripped,
                )
            )
            active = np.ones(idx.size, dtype=bool)
    return LaneResult(st, steps, emax, eend, hist, "numpy")
