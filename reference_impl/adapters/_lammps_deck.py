"""LAMMPS input decks of the assembly runs (contract item 14): what a chain and a lattice share.

A chain (`reference_impl.adapters._lammps_chain`) and a periodic lattice
(`reference_impl.adapters._lammps_lattice`) are the same deck with another box, other
sites and walls: spheres of one radius, ``pair_style granular`` Hertz with no damping
(``damping velocity`` with eta_n0 = 0) and no tangential force, no gravity, ``fix
nve/sphere`` (velocity Verlet); ``fix vector`` records the printed variables at every step
(step 0 included) and ``fix halt`` ends a runaway early. This module writes that deck and
reads the recorded vectors back; each geometry writes only its box, sites, walls and
variables.

Hertz in LAMMPS (documentation of pair granular): F_ne = k_n a delta, a = sqrt(R_eff
delta), R_eff = R/2 between two equal spheres; so k_n = k / sqrt(R/2) in ``pair_coeff``
gives the scene's U' = k q^(3/2) between spheres.
"""

from __future__ import annotations

import math

import numpy as np

from reference_impl.adapters._records import AdapterDeclined

__all__ = ["coeffs", "deck", "hertz_k", "read_vectors"]

# A run stops (fix halt) once its kinetic energy exceeds the request's stop_energy, and at
# most this many times the initial one: the suite's largest energy factor
# (reference_impl.stability.criteria.MAX_FACTOR). A runaway is then not integrated on to
# its end: a striker thrown through a wall at 2000 m/s made the shrink-wrapped box grow and
# rebuild its neighbour lists every step (20 s for 2000 steps).
_HALT = 1e12


def hertz_k(req, what: str) -> float:
    """The Hertz coefficient k (N/m^1.5) of an assembly's law U' = k q^(3/2).

    Raises
    ------
    AdapterDeclined
        The law is not Hertz (pair granular ``hertz`` is U' = k q^(3/2)); ``what`` (e.g.
        ``"chains"``) names the assemblies in the one line.
    """
    pot = req.potential
    if type(pot).__name__ != "PowerLaw" or getattr(pot, "p", None) != 1.5:
        raise AdapterDeclined(f"lammps runs Hertz {what} only (power law, p = 1.5), got {pot!r}")
    return float(pot.k)


def coeffs(k_n: float) -> str:
    """Granular coefficients of Hertz with k_n (Pa, LAMMPS' k_n), no damping, no tangential."""
    return f"hertz {k_n!r} 0.0 tangential linear_nohistory 0.0 0.0 damping velocity"


def deck(req, k: float, *, boundary: str, region: str, sites, velocities: list[str],
         walls: list[str], variables: list[str], names: list[str]) -> str:  # fmt: skip
    """The input script of one run of ``req.n_steps`` steps, recording ``names`` every step.

    Parameters
    ----------
    req : ChainRequest or LatticeRequest
        The assembly (radius R in m, masses in kg, step dt in s, its stop energy in J).
    k : float
        Its Hertz coefficient (N/m^1.5, `hertz_k`).
    boundary : str
        LAMMPS' ``boundary`` of x, y, z.
    region : str
        The box's ``region box block ...`` line (m).
    sites : iterable of (float, float, float)
        Initial centres (m).
    velocities : list of str
        ``set atom`` lines of the non-zero initial velocities.
    walls : list of str
        Wall fixes, after the integrator.
    variables : list of str
        The ``variable`` lines that ``names`` read.
    names : list of str
        The recorded quantities (``v_x1`` ...); read back as vectors ``a0 ..`` in this order.

    Returns
    -------
    str
        The script.
    """
    R = float(req.radius)
    k_n = k / math.sqrt(0.5 * R)
    lines = [
        "units si", "atom_style sphere", "atom_modify map array", f"boundary {boundary}",
        "newton off", "comm_modify vel yes", region, "create_box 1 box",
    ]  # fmt: skip
    for x, y, z in sites:
        lines.append(f"create_atoms 1 single {x!r} {y!r} {z!r} units box")
    for i, m in enumerate(req.masses):
        lines += [f"set atom {i + 1} diameter {2 * R!r}", f"set atom {i + 1} mass {float(m)!r}"]
    lines.append("velocity all set 0.0 0.0 0.0 units box")
    lines += velocities
    lines += [
        f"neighbor {0.5 * R!r} bin", "neigh_modify every 1 delay 0 check yes",
        "pair_style granular", f"pair_coeff * * {coeffs(k_n)}", "fix int all nve/sphere",
    ]  # fmt: skip
    lines += walls
    lines += variables
    lines += [
        f"timestep {req.dt!r}", "thermo 0", "variable ke equal ke",
        f"fix tr all vector 1 {' '.join(names)}",
        # after fix vector: the step that crosses is recorded, then the run ends
        f"fix halt all halt 1 v_ke > {req.stop_kinetic(_HALT)!r} error continue message no",
        f"run {int(req.n_steps)}",
    ]  # fmt: skip
    for c in range(len(names)):
        lines.append(f"variable a{c} vector f_tr[{c + 1}]")
    return "\n".join(lines) + "\n"


def read_vectors(lmp, module, req, width: int, meta: dict):
    """The recorded vectors ``a0 .. a{width-1}`` of a finished run, one row per sample.

    Returns
    -------
    data : numpy.ndarray
        Shape (samples, width); a halted run has fewer than n_steps + 1 samples, ending at
        its first sample over the stop energy.
    meta : dict
        ``meta``, with ``halted_at_step`` where the run was halted.
    """
    vec = module.LMP_VAR_VECTOR
    cols = [np.array(lmp.numpy.extract_variable(f"a{c}", vartype=vec), dtype=float)
            for c in range(width)]  # fmt: skip
    data = np.column_stack(cols)
    if data.shape[0] < req.n_steps + 1:
        meta = {**meta, "halted_at_step": int(data.shape[0] - 1)}
    return data, meta
