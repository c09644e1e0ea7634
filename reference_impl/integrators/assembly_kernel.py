"""Velocity Verlet on assemblies: the one step `_assembly_kdk` and its compiled lanes.

An assembly (`reference_impl.assembly.geometry`) is many bodies joined by contacts. A
contact with a reference length L_c > 0 (``length``) follows its line of centres: overlap
q_c = off_c + L_c - |L_c n_c + u_j - u_i|, force along the current unit vector from i to
j (finite displacements, the codes' model); one with L_c = 0 (a wall, a chain, every
contact when ``length`` is None) has the fixed normal n_c: q_c = off_c + (u_i - u_j) . n_c
(small displacements about the sites). Only this geometry differs between the two: the
step, the law and the dashpot are the same code. The normal force of a contact is the potential's U'(q) from its term table
(`reference_impl.potentials._terms`, read by `verlet_kernel._force_energy`, so every
family with a table runs here), only while q > 0 unless the springs are bonded (then
U'(|q|) sign q: a spring that pulls as well as pushes); the universal dashpot adds
c_c U'/sqrt(2U) dq/dt with the half-step velocities, as the single-contact step does.
Tangential springs (bonded linear assemblies) add k_t delta_t at the contact point and,
with rotations, its torque, always about the fixed normal (the small-displacement model
of bonded springs, whose linear theory the suite checks).

`_assembly_kdk` is the one source of the step (kick, drift, forces at the new position,
kick), written like `verlet_kernel._kdk` so that one body between two walls runs bit for
bit as the single-contact lanes: the same operations in the same order. `_lanes` runs
many lanes (a time step and a scaling of the initial velocities each) in parallel with
``numba.prange``, each for at most ``budget`` steps per call; the state of unfinished
lanes is kept in the caller's arrays, so a long ensemble returns to Python (Ctrl-C, a
progress line) between calls. Lane statuses and the runaway rule (cross the energy
limit, then confirm or stay bounded) are those of `verlet_kernel` (`STATUS_NAMES`).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from reference_impl.integrators.verlet_kernel import (
    _BEYOND,
    _CONTACT,
    _FREE,
    _PENDING,
    _RUNNING,
    _ST_BLOWN,
    _ST_BOUNDED,
    _ST_COMPLETED,
    _ST_OVER_LIMIT,
    _force_energy,
)

__all__ = ["ST_RUNNING", "ST_PENDING"]

ST_PENDING = _PENDING
ST_RUNNING = _RUNNING


@numba.njit(cache=True, inline="always")
def _line_of_centres(u, i, j, nrm, c, d, L):
    """(L_c - |L_c n_c + u_j - u_i| (m), the current unit vector from i to j) of contact c.

    L - r is written -(2 L n.du + du.du) / (L + r), du = u_j - u_i: no cancellation of two
    numbers ~L (the overlap ~1e-4 L would keep only ~12 digits). Three scalar components
    (zeros beyond ``d``): no array is allocated in the step.
    """
    x0 = u[j, 0] - u[i, 0]
    x1 = u[j, 1] - u[i, 1] if d > 1 else 0.0
    x2 = u[j, 2] - u[i, 2] if d > 2 else 0.0
    n0 = nrm[c, 0]
    n1 = nrm[c, 1] if d > 1 else 0.0
    n2 = nrm[c, 2] if d > 2 else 0.0
    s0 = L * n0 + x0
    s1 = L * n1 + x1
    s2 = L * n2 + x2
    r = math.sqrt(s0 * s0 + s1 * s1 + s2 * s2)
    dn = n0 * x0 + n1 * x1 + n2 * x2
    dd = x0 * x0 + x1 * x1 + x2 * x2
    return -(2.0 * L * dn + dd) / (L + r), s0 / r, s1 / r, s2 / r


@numba.njit(cache=True, inline="always")
def _push(F, i, j, f, e0, e1, e2, d):
    """Add the force f (N) along -e on body i and +e on body j (j < 0: a wall)."""
    F[i, 0] -= f * e0
    if j >= 0:
        F[j, 0] += f * e0
    if d > 1:
        F[i, 1] -= f * e1
        if j >= 0:
            F[j, 1] += f * e1
    if d > 2:
        F[i, 2] -= f * e2
        if j >= 0:
            F[j, 2] += f * e2


@numba.njit(cache=True, inline="always")
def _contact_forces(
    u, v, th, F, T, ci, cj, nrm, off, radius, kt, tangential, c_damp, bonded, q_sup, fam, par,
    length,
):  # fmt: skip
    """Forces F (N), torques T (N m), potential energy (J), largest overlap (m), state.

    ``v`` holds the half-step velocities (the dashpot's); ``tangential`` says whether any
    contact has a tangential spring (one test per step instead of one per contact);
    ``length`` (m, or None) the contacts' reference lengths, > 0 for those that follow
    their line of centres. State is `_BEYOND` when an overlap leaves the potential's
    domain or is nan (forces then incomplete).
    """
    n, d = u.shape
    r = th.shape[1]
    for b in range(n):
        for k in range(d):
            F[b, k] = 0.0
        for k in range(r):
            T[b, k] = 0.0
    U = 0.0
    qmax = -math.inf
    state = _FREE
    for c in range(ci.shape[0]):
        i = ci[c]
        j = cj[c]
        L = 0.0
        if length is not None:
            L = length[c]
        if L > 0.0 and j >= 0:
            dq_geo, e0, e1, e2 = _line_of_centres(u, i, j, nrm, c, d, L)
            q = off[c] + dq_geo
        else:
            dot = 0.0
            for k in range(d):
                uj = u[j, k] if j >= 0 else 0.0
                dot += (u[i, k] - uj) * nrm[c, k]
            q = off[c] + dot
            e0 = nrm[c, 0]
            e1 = nrm[c, 1] if d > 1 else 0.0
            e2 = nrm[c, 2] if d > 2 else 0.0
        if q > qmax:
            qmax = q
        if q > 0.0 or (bonded and q < 0.0):
            qa = abs(q)
            if not qa <= q_sup:  # also catches nan
                return U, qmax, _BEYOND
            fe, Uc = _force_energy(qa, fam, par)
            if q < 0.0:
                fe = -fe
            U += Uc
            # repulsive force fe along -e on i, +e on j (the single step's F = sgn fe)
            _push(F, i, j, fe, e0, e1, e2, d)
            if c_damp[c] > 0.0 and Uc > 0.0:
                # dq/dt = (v_i - v_j) . e in both models (d|s|/dt = e . ds/dt); summed
                # from 0.0 as before, so that a fixed normal gives the same bits
                dq = 0.0
                dq += (v[i, 0] - (v[j, 0] if j >= 0 else 0.0)) * e0
                if d > 1:
                    dq += (v[i, 1] - (v[j, 1] if j >= 0 else 0.0)) * e1
                if d > 2:
                    dq += (v[i, 2] - (v[j, 2] if j >= 0 else 0.0)) * e2
                fd = c_damp[c] * abs(fe) / math.sqrt(2.0 * Uc) * dq
                _push(F, i, j, fd, e0, e1, e2, d)
            state = _CONTACT
        if tangential and kt[c] > 0.0:
            U += _tangential(u, th, F, T, i, j, nrm, c, d, r, radius, kt[c])
    return U, qmax, state


@numba.njit(cache=True, inline="always")
def _tangential(u, th, F, T, i, j, nrm, c, d, r, radius, kt):
    """Tangential spring k_t delta_t of contact c: adds forces and torques, returns its energy.

    delta = (u_j - u_i) - R (theta_i + theta_j) x n, delta_t its part across n; the force
    k_t delta_t acts on i (minus on j), the torque R n x (k_t delta_t) on both. Written in
    three scalar components (a 1-D or 2-D assembly has zeros in the others): no array is
    allocated in the step.
    """
    n0 = nrm[c, 0]
    n1 = nrm[c, 1] if d > 1 else 0.0
    n2 = nrm[c, 2] if d > 2 else 0.0
    r0 = (u[j, 0] if j >= 0 else 0.0) - u[i, 0]
    r1 = 0.0
    r2 = 0.0
    if d > 1:
        r1 = (u[j, 1] if j >= 0 else 0.0) - u[i, 1]
    if d > 2:
        r2 = (u[j, 2] if j >= 0 else 0.0) - u[i, 2]
    if r > 0:
        s0 = 0.0  # theta_i + theta_j (2-D: about z only)
        s1 = 0.0
        s2 = th[i, r - 1] + (th[j, r - 1] if j >= 0 else 0.0)
        if r == 3:
            s0 = th[i, 0] + (th[j, 0] if j >= 0 else 0.0)
            s1 = th[i, 1] + (th[j, 1] if j >= 0 else 0.0)
        r0 -= radius * (s1 * n2 - s2 * n1)
        r1 -= radius * (s2 * n0 - s0 * n2)
        r2 -= radius * (s0 * n1 - s1 * n0)
    dn = r0 * n0 + r1 * n1 + r2 * n2
    t0 = r0 - dn * n0
    t1 = r1 - dn * n1
    t2 = r2 - dn * n2
    f0 = kt * t0
    f1 = kt * t1
    f2 = kt * t2
    F[i, 0] += f0
    if j >= 0:
        F[j, 0] -= f0
    if d > 1:
        F[i, 1] += f1
        if j >= 0:
            F[j, 1] -= f1
    if d > 2:
        F[i, 2] += f2
        if j >= 0:
            F[j, 2] -= f2
    if r > 0:  # torque R n x f on both bodies
        q2 = radius * (n0 * f1 - n1 * f0)
        T[i, r - 1] += q2
        if j >= 0:
            T[j, r - 1] += q2
        if r == 3:
            q0 = radius * (n1 * f2 - n2 * f1)
            q1 = radius * (n2 * f0 - n0 * f2)
            T[i, 0] += q0
            T[i, 1] += q1
            if j >= 0:
                T[j, 0] += q0
                T[j, 1] += q1
    return 0.5 * (f0 * t0 + f1 * t1 + f2 * t2)


@numba.njit(cache=True, inline="always")
def _assembly_kdk(
    u, v, th, w, F, T, half, half_i, dt, ci, cj, nrm, off, radius, kt, tangential, c_damp,
    bonded, q_sup, fam, par, mass, inertia, length,
):  # fmt: skip
    """One velocity-Verlet step of every body: half kick, drift, forces, half kick.

    Updates ``u``, ``v`` (m, m/s, shape (n, dim)), ``th``, ``w`` (rad, rad/s, shape (n,
    rot_dim)), ``F``, ``T`` in place; ``half`` = dt / (2 m) (s/kg), ``half_i`` = dt / (2 I).
    Returns (U (J) at the new position, kinetic energy (J) at the new velocities, summed
    in the second kick's pass as `_kinetic` sums it, largest overlap (m), contact state).
    """
    n, d = u.shape
    r = th.shape[1]
    for b in range(n):
        for k in range(d):
            v[b, k] = v[b, k] + half[b] * F[b, k]
            u[b, k] = u[b, k] + dt * v[b, k]
        for k in range(r):
            w[b, k] = w[b, k] + half_i[b] * T[b, k]
            th[b, k] = th[b, k] + dt * w[b, k]
    U, qmax, state = _contact_forces(
        u, v, th, F, T, ci, cj, nrm, off, radius, kt, tangential, c_damp, bonded, q_sup, fam, par,
        length,
    )  # fmt: skip
    ke = 0.0
    if state == _BEYOND:
        return U, ke, qmax, state
    for b in range(n):
        for k in range(d):
            vk = v[b, k] + half[b] * F[b, k]
            v[b, k] = vk
            ke += 0.5 * mass[b] * vk * vk
        for k in range(r):
            wk = w[b, k] + half_i[b] * T[b, k]
            w[b, k] = wk
            ke += 0.5 * inertia[b] * wk * wk
    return U, ke, qmax, state


@numba.njit(cache=True, inline="always")
def _kinetic(v, w, mass, inertia):
    """Kinetic energy (J): sum of m v^2 / 2 and I w^2 / 2."""
    e = 0.0
    for b in range(v.shape[0]):
        for k in range(v.shape[1]):
            e += 0.5 * mass[b] * v[b, k] * v[b, k]
        for k in range(w.shape[1]):
            e += 0.5 * inertia[b] * w[b, k] * w[b, k]
    return e


@numba.njit(cache=True, parallel=True)
def _lanes(
    fam, par, q_sup, bonded, mass, inertia, ci, cj, nrm, off, radius, kt, c_damp,
    dt, vscale, u0, v0, w0, factor, confirm_level, n_steps, confirm_steps, budget,
    us, vs, ths, ws, Fs, Ts, st, steps, e0, eend, emax, qmax, tripped, length=None,
):  # fmt: skip
    """Advance every unfinished lane by at most ``budget`` steps (lanes in parallel).

    Lane L starts at displacements ``u0``, velocities ``vscale[L] * v0`` and angular
    velocities ``vscale[L] * w0``, and runs with step ``dt[L]``. Its energy E_n (kinetic
    plus U at step n) is watched against ``factor`` E_0: a first crossing is followed on
    for ``confirm_steps`` steps from the start and is a runaway (over-limit) only if E_n
    also exceeds ``confirm_level`` E_0, else the lane ends bounded; a lane that crosses
    nothing ends completed after ``n_steps``; an overlap beyond q_sup or a non-finite
    energy ends it blown. The per-lane arrays ``us`` ... ``tripped`` hold the state
    between calls (``st`` `ST_PENDING` before the first); finished lanes keep their
    status, steps, E_0, last and largest energy (J) and largest overlap (m). ``length``:
    the contacts' reference lengths (m) where they follow their lines of centres; None
    (the default, so that callers written before it run as they did) for fixed normals.
    """
    n_lanes = dt.shape[0]
    n = mass.shape[0]
    tangential = False
    for c in range(kt.shape[0]):
        if kt[c] > 0.0:
            tangential = True
    half = np.empty((n_lanes, n))
    half_i = np.empty((n_lanes, n))
    for L in numba.prange(n_lanes):
        if st[L] != _PENDING and st[L] != _RUNNING:
            continue
        h = dt[L]
        for b in range(n):
            half[L, b] = 0.5 * h / mass[b]
            half_i[L, b] = 0.5 * h / inertia[b] if inertia[b] > 0.0 else 0.0
        u = us[L]
        v = vs[L]
        th = ths[L]
        w = ws[L]
        F = Fs[L]
        T = Ts[L]
        if st[L] == _PENDING:
            u[:, :] = u0
            for b in range(n):
                for k in range(v.shape[1]):
                    v[b, k] = vscale[L] * v0[b, k]
                for k in range(w.shape[1]):
                    w[b, k] = vscale[L] * w0[b, k]
                    th[b, k] = 0.0
            U, qm, state = _contact_forces(
                u, v, th, F, T, ci, cj, nrm, off, radius, kt, tangential, c_damp, bonded,
                q_sup, fam, par, length,
            )  # fmt: skip
            e = _kinetic(v, w, mass, inertia) + U
            e0[L] = e
            emax[L] = e
            eend[L] = e
            qmax[L] = qm
            steps[L] = 0
            tripped[L] = False
            st[L] = _RUNNING
            if state == _BEYOND:
                st[L] = _ST_BLOWN
                continue
        lim = confirm_level * e0[L] if tripped[L] else factor * e0[L]
        nmax = confirm_steps if tripped[L] else n_steps
        for _ in range(budget):
            U, ke, qm, state = _assembly_kdk(
                u, v, th, w, F, T, half[L], half_i[L], h, ci, cj, nrm, off, radius, kt,
                tangential, c_damp, bonded, q_sup, fam, par, mass, inertia, length,
            )  # fmt: skip
            steps[L] += 1
            if qm > qmax[L]:
                qmax[L] = qm
            status = -1
            e = ke + U
            if state == _BEYOND or not e < math.inf:
                status = _ST_BLOWN
            else:
                eend[L] = e
                if e > emax[L]:
                    emax[L] = e
                if e > lim:
                    if not tripped[L] and confirm_level > factor:
                        tripped[L] = True  # first crossing: follow it to the confirmation
                        lim = confirm_level * e0[L]
                        nmax = confirm_steps
                        if e > lim:
                            status = _ST_OVER_LIMIT
                    else:
                        status = _ST_OVER_LIMIT
                if status < 0 and steps[L] >= nmax:
                    status = _ST_BOUNDED if tripped[L] else _ST_COMPLETED
            if status >= 0:
                st[L] = status
                if status == _ST_BLOWN:
                    eend[L] = np.nan
                break
