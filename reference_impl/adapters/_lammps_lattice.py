"""LAMMPS on a periodic lattice of spheres (contract item 14); LAMMPS computes no step advice.

The lattice of a `LatticeRequest` as a LAMMPS user writes it: spheres in a periodic box
(``boundary p p p``; a 2-D layer ``p p f``, its spheres in one plane with no velocity
along z, so that z stays put: no ``dimension 2``, whose discs would change the masses'
meaning), ``pair_style granular`` Hertz with k_n = k / sqrt(R/2) (as for a chain,
`reference_impl.adapters._lammps_chain`), no damping, no tangential force, no gravity,
``fix nve/sphere`` (velocity Verlet); ``fix vector`` records every body's position and
velocity at every step (step 0 included) and ``fix halt`` ends a runaway early.
"""

from __future__ import annotations

import math

import numpy as np

from reference_impl.adapters._lattice_request import LatticeRequest, LatticeRun
from reference_impl.adapters._records import AdapterDeclined

__all__ = ["lattice_script", "lattice_vectors"]

# A run stops (fix halt) once its kinetic energy exceeds the request's stop_energy, at most
# this many times the initial one: the suite's largest energy factor, as for a chain.
_HALT = 1e12
_COMPONENTS = ("x", "y", "z", "vx", "vy", "vz")


def lattice_script(req: LatticeRequest) -> str:
    """The input script of one lattice run of ``n_steps`` steps (vectors ``a0 .. a{6N-1}``).

    Raises
    ------
    AdapterDeclined
        The law is not Hertz (pair granular ``hertz`` is U' = k q^(3/2)).
    """
    pot = req.potential
    if type(pot).__name__ != "PowerLaw" or getattr(pot, "p", None) != 1.5:
        raise AdapterDeclined(f"lammps runs Hertz lattices only (power law, p = 1.5), got {pot!r}")
    R, n, k = float(req.radius), req.n_bodies, float(pot.k)
    lx, ly, lz = req.box
    k_n = k / math.sqrt(0.5 * R)
    lines = [
        "units si", "atom_style sphere", "atom_modify map array",
        f"boundary {' '.join('p' if p else 'f' for p in req.periodic)}",
        "newton off", "comm_modify vel yes",
        f"region box block 0.0 {lx!r} 0.0 {ly!r} 0.0 {lz!r}", "create_box 1 box",
    ]  # fmt: skip
    for x, y, z in req.positions.tolist():
        lines.append(f"create_atoms 1 single {x!r} {y!r} {z!r} units box")
    for i, m in enumerate(req.masses):
        lines += [f"set atom {i + 1} diameter {2 * R!r}", f"set atom {i + 1} mass {float(m)!r}"]
    lines.append("velocity all set 0.0 0.0 0.0 units box")
    for i, (vx, vy, vz) in enumerate(req.velocities.tolist()):
        if vx or vy or vz:
            lines.append(f"set atom {i + 1} vx {vx!r} vy {vy!r} vz {vz!r}")
    lines += [
        f"neighbor {0.5 * R!r} bin", "neigh_modify every 1 delay 0 check yes",
        "pair_style granular",
        f"pair_coeff * * hertz {k_n!r} 0.0 tangential linear_nohistory 0.0 0.0 damping velocity",
        "fix int all nve/sphere",
    ]  # fmt: skip
    names = []
    for i in range(n):
        for a in _COMPONENTS:
            lines.append(f"variable {a}{i + 1} equal {a}[{i + 1}]")
            names.append(f"v_{a}{i + 1}")
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


def lattice_vectors(lmp, module, req: LatticeRequest, meta: dict) -> LatticeRun:
    """The recorded vectors of a finished run as a `LatticeRun` (a halted run ends early)."""
    n = req.n_bodies
    vec = module.LMP_VAR_VECTOR
    cols = [np.array(lmp.numpy.extract_variable(f"a{c}", vartype=vec), dtype=float)
            for c in range(6 * n)]  # fmt: skip
    data = np.column_stack(cols).reshape(-1, n, 6)
    if data.shape[0] < req.n_steps + 1:
        meta = {**meta, "halted_at_step": int(data.shape[0] - 1)}
    return LatticeRun(data[:, :, :3], data[:, :, 3:], meta)
