"""LIGGGHTS on a periodic lattice of spheres (contract item 14) and its own step advice.

The lattice of a `LatticeRequest` as a LIGGGHTS user writes it: spheres of atom type 1 in a
periodic box (``boundary p p p``; a 2-D layer ``p p f``, its spheres in one plane with no
velocity along z, so that z stays put), ``pair_style gran model hertz tangential
no_history`` (normal Hertz only: no tangential force, no torque), no gravity, ``fix
nve/sphere``; one ``fix print`` line ``HCVL x_1 y_1 z_1 .. vz_N`` after every step.
Materials, densities and masses as for a chain (`reference_impl.adapters._liggghts_chain`:
Y = 2 (3/4) k / sqrt(R/2), nu = 0, density m / (4/3 pi R^3), each mass then set exactly).

Step advice: ``fix check/timestep/gran`` as for a chain (its Rayleigh time and its Hertz
time from the largest speed after one step), read back as LIGGGHTS computed them.
"""

from __future__ import annotations

import math

import numpy as np

from reference_impl.adapters._lattice_request import LatticeRequest, LatticeRun
from reference_impl.adapters._records import AdapterDeclined, AdapterRunError

__all__ = ["lattice_advice_script", "lattice_mapping", "lattice_script", "parse_lattice"]

# fix check/timestep/gran's warning fractions: they choose only when it warns (as for a chain)
_WARN_FRACTION = 1.0


def lattice_mapping(req: LatticeRequest) -> dict:
    """LIGGGHTS inputs of a lattice: Y, densities, masses (SI units).

    Raises
    ------
    AdapterDeclined
        The law is not Hertz (LIGGGHTS' ``model hertz`` is U' = k q^(3/2)).
    """
    pot = req.potential
    if type(pot).__name__ != "PowerLaw" or getattr(pot, "p", None) != 1.5:
        raise AdapterDeclined(f"liggghts runs Hertz lattices only (power law, p = 1.5), "
                              f"got {pot!r}")  # fmt: skip
    R, k = float(req.radius), float(pot.k)
    vol = 4.0 / 3.0 * math.pi * R**3
    return {
        "model": "hertz",
        "R": R,
        "youngsModulus": 2.0 * 0.75 * k / math.sqrt(0.5 * R),
        "poissonsRatio": 0.0,
        "density": [float(m) / vol for m in req.masses],
        "mass": [float(m) for m in req.masses],
    }


def _head(req: LatticeRequest, mp: dict) -> str:
    """Everything of the script up to the integrator: box, material, bodies, velocities."""
    R, n = req.radius, req.n_bodies
    lx, ly, lz = req.box
    bounds = " ".join("p" if p else "f" for p in req.periodic)
    lines = [
        "atom_style granular", "atom_modify map array", f"boundary {bounds}", "newton off",
        "communicate single vel yes", "units si",
        # Y > 1e9 Pa is refused in SI units without this (global_properties.cpp:370)
        "hard_particles yes",
        f"region reg block 0.0 {lx!r} 0.0 {ly!r} 0.0 {lz!r} units box",
        "create_box 1 reg", f"neighbor {0.5 * R!r} bin", "neigh_modify delay 0",
        f"fix m1 all property/global youngsModulus peratomtype {mp['youngsModulus']!r}",
        "fix m2 all property/global poissonsRatio peratomtype 0.0",
        # restitution 1: the Hertz model's dashpot is zero (log e = 0); no friction
        "fix m3 all property/global coefficientRestitution peratomtypepair 1 1.0",
        "fix m4 all property/global coefficientFriction peratomtypepair 1 0.0",
        "fix m5 all property/global characteristicVelocity scalar 1.0",
        "pair_style gran model hertz tangential no_history", "pair_coeff * *",
        f"timestep {req.dt!r}",
    ]  # fmt: skip
    for x, y, z in req.positions.tolist():
        lines.append(f"create_atoms 1 single {x!r} {y!r} {z!r} units box")
    for i in range(n):
        lines += [
            f"set atom {i + 1} diameter {2.0 * R!r}",
            f"set atom {i + 1} density {mp['density'][i]!r}",
            f"set atom {i + 1} mass {mp['mass'][i]!r}",
        ]
    lines.append("velocity all set 0.0 0.0 0.0 units box")
    for i, (vx, vy, vz) in enumerate(req.velocities.tolist()):
        if vx or vy or vz:
            lines.append(f"set atom {i + 1} vx {vx!r} vy {vy!r} vz {vz!r}")
    for i in range(n):
        for a in ("x", "y", "z", "vx", "vy", "vz"):
            lines.append(f"variable {a}{i + 1} equal {a}[{i + 1}]")
    lines += [
        "variable na equal count(all)",
        "fix int all nve/sphere",
        "thermo 0",
        "thermo_modify lost ignore",
    ]  # a lost body is counted (HCVL ${na}): blown
    return "\n".join(lines) + "\n"


def lattice_script(req: LatticeRequest, mp: dict) -> str:
    """The input script of one lattice run: ``n_steps`` steps, one HCVL line after each."""
    fields = " ".join(f"${{{a}{i + 1}}}" for i in range(req.n_bodies)
                      for a in ("x", "y", "z", "vx", "vy", "vz"))  # fmt: skip
    return (
        _head(req, mp)
        + f'fix pr all print 1 "HCVL ${{na}} {fields}" screen yes title none\n'
        + f"run {int(req.n_steps)}\n"
    )


def lattice_advice_script(req: LatticeRequest, mp: dict) -> str:
    """The script that asks ``fix check/timestep/gran`` for its two times: one step."""
    f = _WARN_FRACTION
    return (
        _head(req, mp)
        + f"fix ct all check/timestep/gran 1 {f!r} {f!r}\n"
        + "variable fr equal f_ct[1]\nvariable fh equal f_ct[2]\n"
        + 'run 1\nprint "HCVADV ${fr} ${fh}"\n'
    )


def parse_lattice(out: str, req: LatticeRequest, meta: dict) -> LatticeRun:
    """The ``HCVL`` lines of a run as a `LatticeRun` (sample 0: the request's start; a
    sample after a body was lost is NaN: blown)."""
    n = req.n_bodies
    rows = [ln.split()[1:] for ln in out.splitlines() if ln.startswith("HCVL ")]
    try:
        data = np.array(rows, dtype=float).reshape(len(rows), 1 + 6 * n)
    except ValueError:
        raise AdapterRunError("liggghts printed a malformed lattice line", out[-4000:]) from None
    lost = np.flatnonzero(data[:, 0] < n)
    body = data[:, 1:].reshape(len(rows), n, 6)
    if lost.size:
        body[lost[0] :] = np.nan
        meta = {**meta, "lost_at_step": int(lost[0] + 1)}
    x = np.concatenate([req.positions[None], body[:, :, :3]])
    v = np.concatenate([req.velocities[None], body[:, :, 3:]])
    return LatticeRun(x, v, meta)
