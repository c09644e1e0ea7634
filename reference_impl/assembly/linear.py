"""The linear theory of an assembly of bonded springs: stiffness matrix and 2 / omega_max.

For springs that never open, with U = k q^2 / 2 along the normal and k_t |delta_t|^2 / 2
across it (`reference_impl.assembly.geometry` gives the kinematics), the equations of
motion are M x'' = -K x; velocity Verlet on them is stable exactly for
omega_max Delta t < 2, omega_max^2 the largest eigenvalue of M^(-1/2) K M^(-1/2): each
mode is a scalar Verlet oscillator, whose amplification matrix has trace
2 - (omega Delta t)^2 and determinant 1, so it is bounded iff |2 - (omega Delta t)^2| < 2.
This module is the reference that the search on such scenes must reproduce; it never runs
the integrator.
"""

from __future__ import annotations

import math

import numpy as np

from reference_impl.assembly.geometry import Assembly
from reference_impl.potentials._terms import TERM_POWER, term_rows

__all__ = ["dt_crit_linear", "linear_k", "omega_max", "stiffness_matrix"]

# Largest matrix this module diagonalises densely (n_dof^2 doubles, ~0.5 GB at 8000).
_MAX_DOF = 8000


def _cross_matrix(n: np.ndarray) -> np.ndarray:
    """[n]_x, the matrix of n x (.) (3-D)."""
    return np.array([[0.0, -n[2], n[1]], [n[2], 0.0, -n[0]], [-n[1], n[0], 0.0]])


def stiffness_matrix(asm: Assembly, k: float) -> tuple[np.ndarray, np.ndarray]:
    """(K, diagonal of M) of the assembly with normal springs k and tangential k_t = ratio k.

    Degrees of freedom per body: its ``dim`` displacements (m), then its ``rot_dim``
    rotations (rad). K in N/m (N m/rad for rotations), M in kg (kg m^2).

    Parameters
    ----------
    asm : Assembly
        The contact network.
    k : float
        Normal spring stiffness (N/m).
    """
    d, r = asm.dim, asm.rot_dim
    per = d + r
    nd = asm.n_bodies * per
    if nd > _MAX_DOF:
        raise ValueError(f"{nd} degrees of freedom; the dense reference stops at {_MAX_DOF}")
    K = np.zeros((nd, nd))
    kt = asm.tangential_ratio * k
    for c in range(asm.n_contacts):
        i, j, n = int(asm.ci[c]), int(asm.cj[c]), asm.normal[c]
        # q = off + (u_i - u_j) . n: gradient +n on i, -n on j
        g = np.zeros(nd)
        g[i * per : i * per + d] = n
        if j >= 0:
            g[j * per : j * per + d] = -n
        K += k * np.outer(g, g)
        if kt == 0.0:
            continue
        # delta = (u_j - u_i) - R (theta_i + theta_j) x n, in 3 components, projected
        n3 = np.zeros(3)
        n3[:d] = n
        G = np.zeros((3, nd))
        G[:d, i * per : i * per + d] = -np.eye(d)
        if j >= 0:
            G[:d, j * per : j * per + d] = np.eye(d)
        if r:
            # theta x n = -[n]_x theta; 2-D: theta along z
            rot = -_cross_matrix(n3) * asm.radius
            rot = rot[:, 2:3] if r == 1 else rot
            for b in (i, j):
                if b >= 0:
                    G[:, b * per + d : b * per + per] -= rot
        P = np.eye(3) - np.outer(n3, n3)
        K += kt * G.T @ P @ G
    M = np.zeros(nd)
    for b in range(asm.n_bodies):
        M[b * per : b * per + d] = asm.mass[b]
        M[b * per + d : (b + 1) * per] = asm.inertia[b]
    return K, M


def omega_max(asm: Assembly, k: float) -> float:
    """The largest angular frequency (rad/s) of the bonded linear assembly (eigvalsh)."""
    K, M = stiffness_matrix(asm, k)
    s = 1.0 / np.sqrt(M)
    lam = np.linalg.eigvalsh(K * s[:, None] * s[None, :])
    return math.sqrt(max(float(lam[-1]), 0.0))


def dt_crit_linear(asm: Assembly, k: float) -> float:
    """2 / omega_max (s): velocity Verlet's exact critical step of the bonded linear assembly."""
    return 2.0 / omega_max(asm, k)


def linear_k(pot) -> float | None:
    """k (N/m) of a linear spring law U = k q^2 / 2 (one power row of the term table with
    n = 2), else None."""
    rows = term_rows(pot)
    if rows is None or len(rows) != 1 or rows[0][0] != TERM_POWER or rows[0][2] != 2.0:
        return None
    return rows[0][1]
