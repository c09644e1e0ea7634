"""LIGGGHTS on a chain of spheres (contract item 14) and its own step advice.

The chain of a `ChainRequest` as a LIGGGHTS user writes it: spheres of atom type 1 on
the x axis (``pair_style gran model hertz``), walls ``fix wall/gran ... primitive type 2
xplane`` of material type 2, no gravity, ``fix nve/sphere``; one ``fix print`` line
``HCVC x_1 .. x_N v_1 .. v_N`` after every step. The deck, the spheres' material and the
step advice are a lattice's too (`reference_impl.adapters._liggghts_deck`); a chain adds
its box and its walls.

Hertz on a wall in LIGGGHTS 3.8.0 has R_eff = R (R/2 between two spheres,
`reference_impl.adapters._liggghts_deck`). With nu = 0 and the spheres' Y_1 = 2 (3/4) k /
sqrt(R/2), the walls' Y_2 with 1/Y_2 = sqrt(R) / (3/4 k) - 1/Y_1 gives the scene's k on a
wall (a wall of the spheres' own material would be sqrt(2) stiffer).
"""

from __future__ import annotations

import math

import numpy as np

from reference_impl.adapters._assembly_request import ChainRequest, ChainRun
from reference_impl.adapters._liggghts_deck import (
    MODEL,
    advice_script,
    deck,
    hertz_mapping,
    parse_advice,
    read_rows,
    run_script,
)

__all__ = ["chain_advice_script", "chain_mapping", "chain_script", "parse_advice", "parse_chain"]

# Half-width margin of the box beyond the chain, in units of the distance a body covers in
# the run at the largest speed energy conservation allows: a body that leaves the box
# (lost, and counted) has moved, on average, this many times faster, i.e. held over
# _BOX_SPEEDS^2 = 1e4 times the initial energy: a runaway. A fixed box (rather than a
# shrink-wrapped one) keeps a runaway's run short: a box grown to the bodies' 1e10 m made
# one blown-up run of 2000 steps take 18 s.
_BOX_SPEEDS = 100.0


def chain_mapping(req: ChainRequest) -> dict:
    """LIGGGHTS inputs of a chain: Y of spheres and walls, densities, masses (SI units).

    Raises
    ------
    AdapterDeclined
        The law is not Hertz (LIGGGHTS' ``model hertz`` is U' = k q^(3/2)).
    """
    mp = hertz_mapping(req, "chains")
    y1, k = mp["youngsModulus"], float(req.potential.k)
    mp["youngsModulus"] = [y1, 1.0 / (math.sqrt(mp["R"]) / (0.75 * k) - 1.0 / y1)]
    return mp


def _head(req: ChainRequest, mp: dict) -> str:
    """Everything of the script up to the run: box, materials, walls, bodies."""
    R, n = req.radius, req.n_bodies
    m = np.asarray(req.masses, dtype=float)
    e0 = 0.5 * float(np.sum(m * np.asarray(req.velocities, dtype=float) ** 2))
    reach = _BOX_SPEEDS * math.sqrt(2.0 * e0 / float(m.min())) * req.dt * req.n_steps
    lo, hi = -4.0 * R - reach, 2.0 * R * n + 4.0 * R + reach
    walls = [f"fix w{k} all wall/gran {MODEL} primitive type 2 xplane {plane!r}"
             for k, (plane, _side) in enumerate(req.wall_planes())]  # fmt: skip
    variables = []
    for i in range(n):
        variables += [f"variable x{i + 1} equal x[{i + 1}]", f"variable v{i + 1} equal vx[{i + 1}]"]
    return deck(
        req,
        mp,
        # f: a fixed box; a body that leaves it is lost and counted (_BOX_SPEEDS)
        boundary="f f f",
        region=f"region reg block {lo!r} {hi!r} {-2 * R!r} {2 * R!r} {-2 * R!r} {2 * R!r} "
        "units box",
        youngs=mp["youngsModulus"],
        walls=walls,
        sites=[(x, 0.0, 0.0) for x in req.x0().tolist()],
        velocities=[f"set atom {i + 1} vx {float(v)!r}" for i, v in enumerate(req.velocities) if v],
        variables=variables,
    )


def chain_script(req: ChainRequest, mp: dict) -> str:
    """The input script of one chain run: ``n_steps`` steps, one HCVC line after each."""
    n = req.n_bodies
    fields = " ".join(f"${{x{i + 1}}}" for i in range(n))
    fields += " " + " ".join(f"${{v{i + 1}}}" for i in range(n))
    return run_script(_head(req, mp), "HCVC", fields, req.n_steps)


def chain_advice_script(req: ChainRequest, mp: dict) -> str:
    """The script that asks ``fix check/timestep/gran`` for its two times: one step."""
    return advice_script(_head(req, mp))


def parse_chain(out: str, req: ChainRequest, meta: dict) -> ChainRun:
    """The ``HCVC`` lines of a run as a `ChainRun` (sample 0: the request's start).

    A sample after a body left the box (fewer than N atoms counted) is NaN: blown.
    """
    n = req.n_bodies
    data, meta = read_rows(out, "HCVC", n, 2 * n, "chain", meta)
    x = np.vstack([req.x0()[None, :], data[:, :n]])
    v = np.vstack([np.asarray(req.velocities, dtype=float)[None, :], data[:, n:]])
    return ChainRun(x, v, meta)
