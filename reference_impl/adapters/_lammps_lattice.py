"""LAMMPS on a periodic lattice of spheres (contract item 14); LAMMPS computes no step advice.

The lattice of a `LatticeRequest` as a LAMMPS user writes it: spheres in a periodic box
(``boundary p p p``; a 2-D layer ``p p f``, its spheres in one plane with no velocity
along z, so that z stays put: no ``dimension 2``, whose discs would change the masses'
meaning), ``pair_style granular`` Hertz with k_n = k / sqrt(R/2), no damping, no
tangential force, no gravity, ``fix nve/sphere`` (velocity Verlet); ``fix vector`` records
every body's position and velocity at every step (step 0 included) and ``fix halt`` ends
a runaway early. The deck is a chain's too (`reference_impl.adapters._lammps_deck`); a
lattice adds its box.
"""

from __future__ import annotations

from reference_impl.adapters._lammps_deck import deck, hertz_k, read_vectors
from reference_impl.adapters._lattice_request import LatticeRequest, LatticeRun

__all__ = ["lattice_script", "lattice_vectors"]

_COMPONENTS = ("x", "y", "z", "vx", "vy", "vz")


def lattice_script(req: LatticeRequest) -> str:
    """The input script of one lattice run of ``n_steps`` steps (vectors ``a0 .. a{6N-1}``).

    Raises
    ------
    AdapterDeclined
        The law is not Hertz (pair granular ``hertz`` is U' = k q^(3/2)).
    """
    k = hertz_k(req, "lattices")
    lx, ly, lz = req.box
    velocities = [
        f"set atom {i + 1} vx {vx!r} vy {vy!r} vz {vz!r}"
        for i, (vx, vy, vz) in enumerate(req.velocities.tolist())
        if vx or vy or vz
    ]
    bodies = [(i, a) for i in range(req.n_bodies) for a in _COMPONENTS]
    return deck(
        req,
        k,
        boundary=" ".join("p" if p else "f" for p in req.periodic),
        region=f"region box block 0.0 {lx!r} 0.0 {ly!r} 0.0 {lz!r}",
        sites=req.positions.tolist(),
        velocities=velocities,
        walls=[],
        variables=[f"variable {a}{i + 1} equal {a}[{i + 1}]" for i, a in bodies],
        names=[f"v_{a}{i + 1}" for i, a in bodies],
    )


def lattice_vectors(lmp, module, req: LatticeRequest, meta: dict) -> LatticeRun:
    """The recorded vectors of a finished run as a `LatticeRun` (a halted run ends early)."""
    n = req.n_bodies
    data, meta = read_vectors(lmp, module, req, 6 * n, meta)
    data = data.reshape(-1, n, 6)
    return LatticeRun(data[:, :, :3], data[:, :, 3:], meta)
