"""Delta t_safe of an assembly under three conventions, and the tangent-stiffness step.

Section 6's bound is stated for one body of mass m meeting one contact with energy
E = m v0^2 / 2. In an assembly the mass and the energy of "the" contact are a choice:

``paper``        the striker's mass m and its kinetic energy m v0^2 / 2, as printed;
``reduced``      the reduced mass m_red = m m' / (m + m') of the striker and the body it
                 meets first (m_red = m against a wall) at the closing speed v0, energy
                 m_red v0^2 / 2 (the two-body collision's own energy);
``one_contact``  all of the assembly's initial energy E_0 in one contact of reduced mass
                 m_red (the worst a single contact could be loaded).

Each is `reference_impl.stability.bound.dt_safe` of the normal law at that mass and energy.
"""

from __future__ import annotations

import math

import numpy as np

from reference_impl.assembly.geometry import Assembly
from reference_impl.assembly.lanes import AssemblyModel
from reference_impl.assembly.linear import _MAX_DOF, omega_max
from reference_impl.stability.bound import dt_safe

__all__ = ["CONVENTIONS", "dt_safe_conventions", "striker", "tangent_step"]

CONVENTIONS = ("paper", "reduced", "one_contact")
# Grid of the largest tangent stiffness U'' on [0, q_run] (as `stability.recommend`).
_GRID = np.concatenate([np.logspace(-12, 0, 200), np.linspace(0.0, 1.0, 801)])


def striker(model: AssemblyModel) -> tuple[int, float, float]:
    """(striker body, its speed v0 (m/s), the reduced mass (kg) with the body it meets first).

    The striker is the fastest body; it meets first the partner of its contact most nearly
    along its velocity (a wall: m_red = m).
    """
    a = model.assembly
    speed = np.linalg.norm(model.v_init, axis=1)
    b = int(np.argmax(speed))
    v0 = float(speed[b])
    m = float(a.mass[b])
    best, partner = -math.inf, -1
    for c in range(a.n_contacts):
        for me, other, sign in ((a.ci[c], a.cj[c], 1.0), (a.cj[c], a.ci[c], -1.0)):
            if me != b:
                continue
            along = sign * float(a.normal[c] @ model.v_init[b]) / max(v0, 1e-300)
            if along > best:
                best, partner = along, int(other)
    if partner < 0:
        return b, v0, m
    mp = float(a.mass[partner])
    return b, v0, m * mp / (m + mp)


def dt_safe_conventions(model: AssemblyModel, e0: float) -> dict[str, float]:
    """Delta t_safe (s) of the assembly's normal law under each of `CONVENTIONS`.

    Parameters
    ----------
    model : AssemblyModel
        The assembly and its initial state (the striker's speed sets the energy).
    e0 : float
        The assembly's initial energy (J), for ``one_contact``.
    """
    b, v0, m_red = striker(model)
    m = float(model.assembly.mass[b])
    pot = model.potential
    return {
        "paper": dt_safe(pot, m, v0).dt_safe,
        "reduced": dt_safe(pot, m_red, v0).dt_safe,
        "one_contact": dt_safe(pot, m_red, math.sqrt(2.0 * e0 / m_red)).dt_safe,
    }


def tangent_step(asm: Assembly, pot, q_run: float) -> float:
    """2 / omega_max of the assembly linearised at the stiffest contact met (s).

    Every contact is given the largest tangent stiffness k = max U'' on [0, q_run]
    (q_run the largest overlap met along the run), so omega_max = sqrt(k) omega_1 with
    omega_1 that of unit springs; NaN when U'' is unbounded or the assembly is too large
    for the dense eigenvalues (`reference_impl.assembly.linear`).
    """
    if not (q_run > 0 and math.isfinite(q_run)) or pot.leading_exponent < 2:
        return math.nan
    if asm.n_bodies * (asm.dim + asm.rot_dim) > _MAX_DOF:
        return math.nan
    with np.errstate(all="ignore"):
        k = float(np.nanmax(pot._d2U(np.minimum(q_run * _GRID, pot.q_sup))))
    if not (k > 0 and math.isfinite(k)):
        return math.nan
    return 2.0 / (math.sqrt(k) * omega_max(asm, 1.0))
