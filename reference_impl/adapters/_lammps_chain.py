"""LAMMPS on a chain of spheres (contract item 14); LAMMPS computes no step advice.

The chain of a `ChainRequest` as a LAMMPS user writes it: spheres on the x axis with
``pair_style granular`` Hertz, ``fix wall/gran granular`` planes at the ends, no gravity,
``fix nve/sphere`` (velocity Verlet); ``fix vector`` records the positions and velocities
at every step (step 0 included) and ``fix halt`` ends a runaway early. The deck is a
lattice's too (`reference_impl.adapters._lammps_deck`); a chain adds its box and walls.

Hertz on a wall in LAMMPS has R_eff = R (R/2 between two equal spheres): k_n = k /
sqrt(R) in the walls' own coefficients gives the scene's U' = k q^(3/2) on a wall as
k_n = k / sqrt(R/2) does between spheres.
"""

from __future__ import annotations

import math

from reference_impl.adapters._assembly_request import ChainRequest, ChainRun
from reference_impl.adapters._lammps_deck import coeffs, deck, hertz_k, read_vectors

__all__ = ["chain_script", "chain_vectors"]


def chain_script(req: ChainRequest) -> str:
    """The input script of one chain run of ``n_steps`` steps (sample vectors ``ax1 .. avN``).

    Raises
    ------
    AdapterDeclined
        The law is not Hertz (pair granular ``hertz`` is U' = k q^(3/2)).
    """
    k = hertz_k(req, "chains")
    R, n = float(req.radius), req.n_bodies
    wall = coeffs(k / math.sqrt(R))
    walls = [f"fix w{j} all wall/gran granular {wall} xplane {plane!r} NULL" if side < 0
             else f"fix w{j} all wall/gran granular {wall} xplane NULL {plane!r}"
             for j, (plane, side) in enumerate(req.wall_planes())]  # fmt: skip
    variables = []
    for i in range(n):
        variables += [f"variable x{i + 1} equal x[{i + 1}]", f"variable v{i + 1} equal vx[{i + 1}]"]
    return deck(
        req,
        k,
        boundary="m m m",
        region=f"region box block {-2 * R!r} {2 * R * n + 2 * R!r} {-2 * R!r} {2 * R!r} "
        f"{-2 * R!r} {2 * R!r}",
        sites=[(x, 0.0, 0.0) for x in req.x0().tolist()],
        velocities=[f"set atom {i + 1} vx {float(v)!r}" for i, v in enumerate(req.velocities) if v],
        walls=walls,
        variables=variables,
        names=[f"v_x{i + 1}" for i in range(n)] + [f"v_v{i + 1}" for i in range(n)],
    )


def chain_vectors(lmp, module, req: ChainRequest, meta: dict) -> ChainRun:
    """The recorded vectors of a finished run as a `ChainRun` (a halted run ends early, at
    its first sample over the stop energy)."""
    n = req.n_bodies
    data, meta = read_vectors(lmp, module, req, 2 * n, meta)
    return ChainRun(data[:, :n], data[:, n:], meta)
