"""LAMMPS on a chain of spheres (contract item 14); LAMMPS computes no step advice.

The chain of a `ChainRequest` as a LAMMPS user writes it: spheres on the x axis with
``pair_style granular`` Hertz, ``fix wall/gran granular`` planes at the ends, no gravity,
``fix nve/sphere`` (velocity Verlet); ``fix vector`` records the positions and velocities
at every step (step 0 included) and ``fix halt`` ends a runaway early.

Hertz in LAMMPS (documentation of pair granular): F_ne = k_n a delta, a = sqrt(R_eff
delta), R_eff = R/2 between two equal spheres and R on a wall; so k_n = k / sqrt(R/2) in
``pair_coeff`` and k_n = k / sqrt(R) in the walls' own coefficients give the scene's
U' = k q^(3/2) on every contact. No damping (``damping velocity`` with eta_n0 = 0), no
tangential force.
"""

from __future__ import annotations

import math

import numpy as np

from reference_impl.adapters._assembly_request import ChainRequest, ChainRun
from reference_impl.adapters._records import AdapterDeclined

__all__ = ["chain_script", "chain_vectors"]

# A run stops (fix halt) once its kinetic energy exceeds the request's stop_energy, and at
# most this many times the initial one: the suite's largest energy factor
# (reference_impl.stability.criteria.MAX_FACTOR). A runaway is then not integrated on to
# its end: a striker thrown through a wall at 2000 m/s made the shrink-wrapped box grow and
# rebuild its neighbour lists every step (20 s for 2000 steps).
_HALT = 1e12


def _coeffs(k_n: float) -> str:
    return f"hertz {k_n!r} 0.0 tangential linear_nohistory 0.0 0.0 damping velocity"


def chain_script(req: ChainRequest) -> str:
    """The input script of one chain run of ``n_steps`` steps (sample vectors ``ax1 .. avN``).

    Raises
    ------
    AdapterDeclined
        The law is not Hertz (pair granular ``hertz`` is U' = k q^(3/2)).
    """
    pot = req.potential
    if type(pot).__name__ != "PowerLaw" or getattr(pot, "p", None) != 1.5:
        raise AdapterDeclined(f"lammps runs Hertz chains only (power law, p = 1.5), got {pot!r}")
    R, n, k = float(req.radius), req.n_bodies, float(pot.k)
    m = np.asarray(req.masses, dtype=float)
    lines = [
        "units si", "atom_style sphere", "atom_modify map array", "boundary m m m",
        "newton off", "comm_modify vel yes",
        f"region box block {-2 * R!r} {2 * R * n + 2 * R!r} {-2 * R!r} {2 * R!r} {-2 * R!r} "
        f"{2 * R!r}",
        "create_box 1 box",
    ]  # fmt: skip
    for x in req.x0().tolist():
        lines.append(f"create_atoms 1 single {x!r} 0.0 0.0 units box")
    for i in range(n):
        lines += [f"set atom {i + 1} diameter {2 * R!r}", f"set atom {i + 1} mass {float(m[i])!r}"]
    lines.append("velocity all set 0.0 0.0 0.0 units box")
    for i, v in enumerate(req.velocities):
        if v:
            lines.append(f"set atom {i + 1} vx {float(v)!r}")
    lines += [
        f"neighbor {0.5 * R!r} bin", "neigh_modify every 1 delay 0 check yes",
        "pair_style granular", f"pair_coeff * * {_coeffs(k / math.sqrt(0.5 * R))}",
        "fix int all nve/sphere",
    ]  # fmt: skip
    for j, (plane, _side) in enumerate(req.wall_planes()):
        lines.append(
            f"fix w{j} all wall/gran granular {_coeffs(k / math.sqrt(R))} xplane {plane!r} NULL"
            if _side < 0
            else f"fix w{j} all wall/gran granular {_coeffs(k / math.sqrt(R))} xplane NULL "
            f"{plane!r}"
        )
    names = [f"v_x{i + 1}" for i in range(n)] + [f"v_v{i + 1}" for i in range(n)]
    for i in range(n):
        lines += [f"variable x{i + 1} equal x[{i + 1}]", f"variable v{i + 1} equal vx[{i + 1}]"]
    lines += [
        f"timestep {req.dt!r}", "thermo 0", "variable ke equal ke",
        f"fix tr all vector 1 {' '.join(names)}",
        # after fix vector: the step that crosses is recorded, then the run ends
        f"fix halt all halt 1 v_ke > {req.stop_kinetic(_HALT)!r} error continue message no",
        f"run {int(req.n_steps)}",
    ]  # fmt: skip
    for c in range(2 * n):
        lines.append(f"variable a{c} vector f_tr[{c + 1}]")
    return "\n".join(lines) + "\n"


def chain_vectors(lmp, module, req: ChainRequest, meta: dict) -> ChainRun:
    """The recorded vectors of a finished run as a `ChainRun` (a halted run ends early, at
    its first sample over the stop energy)."""
    n = req.n_bodies
    vec = module.LMP_VAR_VECTOR
    cols = [np.array(lmp.numpy.extract_variable(f"a{c}", vartype=vec), dtype=float)
            for c in range(2 * n)]  # fmt: skip
    data = np.column_stack(cols)
    x, v = data[:, :n], data[:, n:]
    if x.shape[0] < req.n_steps + 1:
        meta = {**meta, "halted_at_step": int(x.shape[0] - 1)}
    return ChainRun(x, v, meta)
