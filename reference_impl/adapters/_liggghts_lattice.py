"""LIGGGHTS on a periodic lattice of spheres (contract item 14) and its own step advice.

The lattice of a `LatticeRequest` as a LIGGGHTS user writes it: spheres of atom type 1 in a
periodic box (``boundary p p p``; a 2-D layer ``p p f``, its spheres in one plane with no
velocity along z, so that z stays put), ``pair_style gran model hertz tangential
no_history`` (normal Hertz only: no tangential force, no torque), no gravity, ``fix
nve/sphere``; one ``fix print`` line ``HCVL x_1 y_1 z_1 .. vz_N`` after every step.
The deck, the material (Y = 2 (3/4) k / sqrt(R/2), nu = 0, density m / (4/3 pi R^3), each
mass then set exactly) and the step advice (``fix check/timestep/gran``: its Rayleigh time
and its Hertz time from the largest speed after one step, read back as LIGGGHTS computed
them) are a chain's too (`reference_impl.adapters._liggghts_deck`); a lattice adds its box.
"""

from __future__ import annotations

import numpy as np

from reference_impl.adapters._lattice_request import LatticeRequest, LatticeRun
from reference_impl.adapters._liggghts_deck import (
    advice_script,
    deck,
    hertz_mapping,
    read_rows,
    run_script,
)

__all__ = ["lattice_advice_script", "lattice_mapping", "lattice_script", "parse_lattice"]

# The numbers printed of each body, in this order (HCVL lines).
_FIELDS = ("x", "y", "z", "vx", "vy", "vz")


def lattice_mapping(req: LatticeRequest) -> dict:
    """LIGGGHTS inputs of a lattice: Y, densities, masses (SI units).

    Raises
    ------
    AdapterDeclined
        The law is not Hertz (LIGGGHTS' ``model hertz`` is U' = k q^(3/2)).
    """
    return hertz_mapping(req, "lattices")


def _head(req: LatticeRequest, mp: dict) -> str:
    """Everything of the script up to the run: box, material, bodies, velocities."""
    lx, ly, lz = req.box
    velocities = [
        f"set atom {i + 1} vx {vx!r} vy {vy!r} vz {vz!r}"
        for i, (vx, vy, vz) in enumerate(req.velocities.tolist())
        if vx or vy or vz
    ]
    return deck(
        req,
        mp,
        boundary=" ".join("p" if p else "f" for p in req.periodic),
        region=f"region reg block 0.0 {lx!r} 0.0 {ly!r} 0.0 {lz!r} units box",
        youngs=[mp["youngsModulus"]],
        walls=[],
        sites=req.positions.tolist(),
        velocities=velocities,
        variables=[
            f"variable {a}{i + 1} equal {a}[{i + 1}]" for i in range(req.n_bodies) for a in _FIELDS
        ],  # fmt: skip
    )


def lattice_script(req: LatticeRequest, mp: dict) -> str:
    """The input script of one lattice run: ``n_steps`` steps, one HCVL line after each."""
    fields = " ".join(f"${{{a}{i + 1}}}" for i in range(req.n_bodies) for a in _FIELDS)
    return run_script(_head(req, mp), "HCVL", fields, req.n_steps)


def lattice_advice_script(req: LatticeRequest, mp: dict) -> str:
    """The script that asks ``fix check/timestep/gran`` for its two times: one step."""
    return advice_script(_head(req, mp))


def parse_lattice(out: str, req: LatticeRequest, meta: dict) -> LatticeRun:
    """The ``HCVL`` lines of a run as a `LatticeRun` (sample 0: the request's start; a
    sample after a body was lost is NaN: blown)."""
    n = req.n_bodies
    data, meta = read_rows(out, "HCVL", n, 6 * n, "lattice", meta)
    body = data.reshape(len(data), n, 6)
    x = np.concatenate([req.positions[None], body[:, :, :3]])
    v = np.concatenate([req.velocities[None], body[:, :, 3:]])
    return LatticeRun(x, v, meta)
