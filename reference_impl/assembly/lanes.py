"""Lanes of one assembly: many (time step, initial state) runs of velocity Verlet at once.

`AssemblyModel` is what the kernel needs of an assembly: its contact network
(`reference_impl.assembly.geometry`), the normal law (a `Potential` with a term table),
whether the springs are bonded, the dashpot and the tangential springs, the initial
velocities and which model of the contact geometry runs (`AssemblyModel.follows`);
`run_lanes` drives `reference_impl.integrators.assembly_kernel._lanes` in
calls of a bounded amount of work until every lane has finished; `displacements` runs one
lane and keeps every step (for comparisons with the codes).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from reference_impl.assembly.geometry import Assembly, overlaps
from reference_impl.errors import HCVInputError
from reference_impl.integrators.assembly_kernel import ST_PENDING, ST_RUNNING, _lanes
from reference_impl.integrators.verlet_kernel import STATUS_NAMES, kernel_terms
from reference_impl.potentials.base import Potential

__all__ = [
    "ULP_SCALE",
    "AssemblyModel",
    "LaneOutcome",
    "cage_fraction",
    "displacements",
    "initial_energy",
    "run_lanes",
]

# Contact updates (lanes x steps x contacts) of one kernel call: ~0.1 s at ~5e7 updates/s
# per core, so Ctrl-C and the progress line get through between calls.
_CALL_UPDATES = 1 << 23
# The ensemble's perturbation: lane k scales every initial velocity by 1 + k ULP_SCALE,
# one unit in the last place of 1 (dimensionless).
ULP_SCALE = math.ldexp(1.0, -52)
# Lanes x bodies held at once (the per-lane state, ~100 B per body and lane).
MAX_LANE_BODIES = 1 << 22


@dataclass(frozen=True)
class AssemblyModel:
    """An assembly with its contact law and initial state, ready for the kernel.

    Attributes
    ----------
    assembly : Assembly
        Bodies and contacts.
    potential : Potential
        The normal contact law U(q) of every contact (term table required).
    bonded : bool
        Springs that pull as well as push (U(|q|), never open).
    zeta : float
        Damping ratio of the universal law on every contact, c = 2 zeta sqrt(m_red)
        (m_red the contact's reduced mass; a wall's body mass); 0 for none.
    k_tangential : float
        Tangential spring stiffness k_t (N/m), 0 for none.
    v_init : numpy.ndarray
        Initial velocities (m/s), shape (n, dim).
    w_init : numpy.ndarray
        Initial angular velocities (rad/s), shape (n, rot_dim).
    follow_normals : bool or None
        Contacts follow their lines of centres (finite displacements, as the codes) or
        keep their reference normals (small displacements); None: the default, see
        `follows`.
    """

    assembly: Assembly
    potential: Potential
    bonded: bool
    zeta: float
    k_tangential: float
    v_init: np.ndarray
    w_init: np.ndarray
    follow_normals: bool | None = None

    @property
    def follows(self) -> bool:
        """Whether the contacts follow their lines of centres.

        Default: yes, but for bonded springs. Their checks are the linear theory
        (2 / omega_max of the stiffness matrix, `reference_impl.assembly.linear`), a
        statement about small displacements, so they keep the fixed normals it
        linearises, and so do their tangential springs (modelled with fixed normals only).
        A chain is the same in both (its lines of centres cannot turn).
        """
        return (not self.bonded) if self.follow_normals is None else bool(self.follow_normals)

    def kernel_lengths(self) -> np.ndarray | None:
        """The kernel's ``length`` argument: reference lengths (m) or None (fixed normals)."""
        lc = self.assembly.length
        if not self.follows or lc is None or not np.any(lc > 0.0):
            return None
        # A writable copy always, as ``vs`` in `run_lanes`: numba compiles _lanes once per
        # read-only/writable pattern of its arguments, and the assembly's arrays may be either.
        return np.array(lc, dtype=float, order="C")

    def contact_damping(self) -> np.ndarray:
        """c_c = 2 zeta sqrt(m_red) of each contact (kg^(1/2))."""
        a = self.assembly
        mi = a.mass[a.ci]
        mj = a.mass[np.maximum(a.cj, 0)]
        m_red = np.where(a.cj >= 0, mi * mj / (mi + mj), mi)
        return 2.0 * self.zeta * np.sqrt(m_red)


@dataclass(frozen=True)
class LaneOutcome:
    """What each lane did (arrays over the lanes).

    Attributes
    ----------
    status : numpy.ndarray
        Index into `STATUS_NAMES` (completed, over-limit, blown, bounded).
    steps : numpy.ndarray
        Steps run.
    e0, e_end, e_max : numpy.ndarray
        Initial, last and largest energy (J); e_end nan for a blown lane.
    q_max : numpy.ndarray
        Largest overlap of any contact over the run (m).
    contact_updates : int
        Lanes x steps x contacts integrated (the work done).
    """

    status: np.ndarray
    steps: np.ndarray
    e0: np.ndarray
    e_end: np.ndarray
    e_max: np.ndarray
    q_max: np.ndarray
    contact_updates: int

    @property
    def failed(self) -> np.ndarray:
        """A runaway: over the confirmation level, or blown."""
        return (self.status == STATUS_NAMES.index("over-limit")) | (
            self.status == STATUS_NAMES.index("blown")
        )

    @property
    def bounded(self) -> np.ndarray:
        """Crossed the first energy level, stayed below the confirmation one."""
        return self.status == STATUS_NAMES.index("bounded")


def _terms(pot: Potential):
    terms = kernel_terms(pot)
    if terms is None:
        raise HCVInputError(
            f"assemblies run a contact law with a term table (reference_impl.potentials._terms); "
            f"{type(pot).__name__} {pot!r} has none"
        )
    return terms


def run_lanes(
    model: AssemblyModel,
    dt,
    vscale,
    *,
    factor: float,
    confirm_level: float,
    n_steps: int,
    confirm_steps: int,
    progress: Callable[[int], None] | None = None,
) -> LaneOutcome:
    """Run velocity Verlet on every lane (``dt[L]``, initial velocities ``vscale[L]`` v_init).

    Parameters
    ----------
    model : AssemblyModel
        The assembly, its law and its initial state.
    dt, vscale : array_like
        Time step (s) and initial-velocity scale (dimensionless) of each lane.
    factor, confirm_level : float
        A lane whose energy crosses factor E_0 is followed on: a runaway if it also
        crosses confirm_level E_0 within ``confirm_steps`` steps, else bounded
        (`reference_impl.stability.criteria.EnergyGrowth`).
    n_steps, confirm_steps : int
        Horizon of a lane, and of a lane followed on to its confirmation.
    progress : callable, optional
        Called with the contact updates done so far after each kernel call.
    """
    a = model.assembly
    fam, par = _terms(model.potential)
    dt = np.ascontiguousarray(np.atleast_1d(np.asarray(dt, dtype=float)))
    # Always a fresh writable copy: ascontiguousarray kept broadcast_to's read-only view
    # for an array of dt's shape but copied a scalar, and numba compiles _lanes once per
    # kind (read-only or not), ~25 s each on a cold cache.
    vs = np.array(np.broadcast_to(np.asarray(vscale, dtype=float), dt.shape), order="C")
    nl, n, d, r = dt.size, a.n_bodies, a.dim, a.rot_dim
    if nl * n > MAX_LANE_BODIES:
        raise HCVInputError(f"{nl} lanes of {n} bodies is more than {MAX_LANE_BODIES} at once")
    if not np.all(np.isfinite(dt) & (dt > 0)):
        raise HCVInputError(f"time steps must be finite and > 0 (s), got {dt[~(dt > 0)][:3]}")
    us, vv = np.zeros((nl, n, d)), np.zeros((nl, n, d))
    ths, ws = np.zeros((nl, n, r)), np.zeros((nl, n, r))
    Fs, Ts = np.zeros((nl, n, d)), np.zeros((nl, n, r))
    st = np.full(nl, ST_PENDING, dtype=np.int64)
    steps = np.zeros(nl, dtype=np.int64)
    e0, eend, emax, qmax = (np.zeros(nl) for _ in range(4))
    tripped = np.zeros(nl, dtype=np.bool_)
    kt = np.full(a.n_contacts, float(model.k_tangential))
    cd = np.ascontiguousarray(model.contact_damping())
    inertia = a.inertia if r else np.zeros(n)
    v0 = np.ascontiguousarray(model.v_init, dtype=float).reshape(n, d)
    w0 = np.ascontiguousarray(model.w_init, dtype=float).reshape(n, r)
    q_sup = float(model.potential.q_sup)
    length = model.kernel_lengths()
    while True:
        live = np.count_nonzero((st == ST_PENDING) | (st == ST_RUNNING))
        if live == 0:
            break
        budget = max(1, _CALL_UPDATES // (live * max(a.n_contacts, 1)))
        _lanes(
            fam, par, q_sup, bool(model.bonded), a.mass, inertia, a.ci, a.cj,
            np.ascontiguousarray(a.normal), a.off, a.radius, kt, cd,
            dt, vs, np.ascontiguousarray(a.u0, dtype=float), v0, w0,
            float(factor), float(confirm_level), int(n_steps), int(confirm_steps), int(budget),
            us, vv, ths, ws, Fs, Ts, st, steps, e0, eend, emax, qmax, tripped, length,
        )  # fmt: skip
        if progress is not None:
            progress(int(steps.sum()) * a.n_contacts)
    return LaneOutcome(
        status=st,
        steps=steps,
        e0=e0,
        e_end=eend,
        e_max=emax,
        q_max=qmax,
        contact_updates=int(steps.sum()) * a.n_contacts,
    )


def initial_energy(model: AssemblyModel) -> float:
    """E_0 (J): kinetic energy of the initial velocities plus U of the initial overlaps
    (bonded springs: U(|q|); tangential springs start unstretched), in the model's geometry."""
    a = model.assembly
    ke = 0.5 * float(np.sum(a.mass[:, None] * model.v_init**2))
    if a.rot_dim:
        ke += 0.5 * float(np.sum(a.inertia[:, None] * model.w_init**2))
    q = overlaps(a, a.u0, model.kernel_lengths() is not None)
    q = np.abs(q) if model.bonded else q
    q = q[q > 0]
    return ke + (float(np.sum(model.potential._U(q))) if q.size else 0.0)


def displacements(model: AssemblyModel, dt: float, n_steps: int, every: int = 1) -> np.ndarray:
    """Displacements u (m) of every body along one lane of the kernel, no energy limit.

    Returns shape (n_samples, n, dim): the start, then every ``every`` steps (and the last
    step), one kernel call per sample. A lane that blows up keeps its last displacements.
    """
    a = model.assembly
    fam, par = _terms(model.potential)
    n, d, r = a.n_bodies, a.dim, a.rot_dim
    if not (math.isfinite(dt) and dt > 0):
        raise HCVInputError(f"the time step must be finite and > 0 (s), got {dt!r}")
    if int(every) < 1:
        raise HCVInputError(f"every must be >= 1 step, got {every!r}")
    us, vv = np.zeros((1, n, d)), np.zeros((1, n, d))
    ths, ws = np.zeros((1, n, r)), np.zeros((1, n, r))
    Fs, Ts = np.zeros((1, n, d)), np.zeros((1, n, r))
    st = np.full(1, ST_PENDING, dtype=np.int64)
    steps = np.zeros(1, dtype=np.int64)
    e0, eend, emax, qmax = (np.zeros(1) for _ in range(4))
    tripped = np.zeros(1, dtype=np.bool_)
    kt = np.full(a.n_contacts, float(model.k_tangential))
    cd = np.ascontiguousarray(model.contact_damping())
    inertia = a.inertia if r else np.zeros(n)
    length = model.kernel_lengths()
    out = [np.array(a.u0, dtype=float).reshape(n, d)]
    done = 0
    while done < int(n_steps):
        budget = min(int(every), int(n_steps) - done)
        # limits and horizon far beyond the run: the lane stops only if it blows up
        _lanes(
            fam, par, float(model.potential.q_sup), bool(model.bonded), a.mass, inertia, a.ci,
            a.cj, np.ascontiguousarray(a.normal), a.off, a.radius, kt, cd, np.array([float(dt)]),
            np.ones(1), np.ascontiguousarray(a.u0, dtype=float),
            np.ascontiguousarray(model.v_init, dtype=float).reshape(n, d),
            np.ascontiguousarray(model.w_init, dtype=float).reshape(n, r),
            1e300, 1e300, 1 << 62, 1 << 62, budget,
            us, vv, ths, ws, Fs, Ts, st, steps, e0, eend, emax, qmax, tripped, length,
        )  # fmt: skip
        done += budget
        out.append(us[0].copy())
    return np.array(out)


def cage_fraction(model: AssemblyModel, dt: float, n_steps: int, every: int = 100) -> float:
    """Largest distance of a body from its site relative to the bodies' mean displacement,
    over one lane of ``n_steps`` at ``dt`` (sampled every ``every`` steps), in units of the
    assembly's cage (`reference_impl.assembly.geometry.Assembly.cage`): below 1 the fixed
    contact list held along the whole run; 0 for a chain (no cage to leave). Sampling
    misses at most the distance a body moves in ``every`` steps."""
    cage = model.assembly.cage
    if not math.isfinite(cage):
        return 0.0
    u = displacements(model, dt, n_steps, every)
    rel = u - u.mean(axis=1, keepdims=True)
    return float(np.max(np.linalg.norm(rel, axis=2))) / cage
