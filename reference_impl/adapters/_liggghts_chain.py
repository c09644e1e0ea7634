"""LIGGGHTS on a chain of spheres (contract item 14) and its own step advice.

The chain of a `ChainRequest` as a LIGGGHTS user writes it: spheres of atom type 1 on
the x axis (``pair_style gran model hertz``), walls ``fix wall/gran ... primitive type 2
xplane`` of material type 2, no gravity, ``fix nve/sphere``; one ``fix print`` line
``HCVC x_1 .. x_N v_1 .. v_N`` after every step.

Hertz in LIGGGHTS 3.8.0 (``normal_model_hertz.h``, see `reference_impl.adapters.liggghts`):
U' = 4/3 Y_eff sqrt(R_eff) q^(3/2) with R_eff = R/2 between two spheres and R on a wall,
1/Y_eff = (1 - nu_a^2)/Y_a + (1 - nu_b^2)/Y_b (``global_properties.cpp``). With nu = 0,
the spheres' Young modulus Y_1 = 2 (3/4) k / sqrt(R/2) gives the scene's k between two
spheres, and the walls' Y_2 with 1/Y_2 = sqrt(R) / (3/4 k) - 1/Y_1 gives the same k on a
wall (a wall of the spheres' own material would be sqrt(2) stiffer). Each sphere's
density is m_i / (4/3 pi R^3), so that the step advice, which reads the density, sees
the scene's bodies; its mass is then set to m_i exactly.

Step advice: ``fix check/timestep/gran 1 f_r f_h`` computes the Rayleigh time and the
Hertz time (the latter from the largest particle speed of the current step) and gives
dt / t_Rayleigh and dt / t_Hertz as ``f_ID[1]``, ``f_ID[2]``; the adapter runs one step
and reads them back (``fix_check_timestep_gran.cpp``): the times are dt over those
fractions, as LIGGGHTS computed them, nothing retyped.
"""

from __future__ import annotations

import math

import numpy as np

from reference_impl.adapters._assembly_request import ChainRequest, ChainRun
from reference_impl.adapters._records import AdapterDeclined, AdapterRunError

__all__ = ["chain_advice_script", "chain_mapping", "chain_script", "parse_advice", "parse_chain"]

# The fractions LIGGGHTS warns at (fix check/timestep/gran's own arguments): they only
# choose when it prints a warning, never the times it computes; 1 keeps the output short.
_WARN_FRACTION = 1.0
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
    pot = req.potential
    p = getattr(pot, "p", None)
    if type(pot).__name__ != "PowerLaw" or p != 1.5:
        raise AdapterDeclined(f"liggghts runs Hertz chains only (power law, p = 1.5), "
                              f"got {pot!r}")  # fmt: skip
    R, k = float(req.radius), float(pot.k)
    y1 = 2.0 * 0.75 * k / math.sqrt(0.5 * R)
    y2 = 1.0 / (math.sqrt(R) / (0.75 * k) - 1.0 / y1)
    vol = 4.0 / 3.0 * math.pi * R**3
    return {
        "model": "hertz",
        "R": R,
        "youngsModulus": [y1, y2],
        "poissonsRatio": 0.0,
        "density": [float(m) / vol for m in req.masses],
        "mass": [float(m) for m in req.masses],
    }


def _head(req: ChainRequest, mp: dict) -> str:
    """Everything of the script up to the integrator: box, materials, walls, bodies."""
    R, n = req.radius, req.n_bodies
    m = np.asarray(req.masses, dtype=float)
    e0 = 0.5 * float(np.sum(m * np.asarray(req.velocities, dtype=float) ** 2))
    reach = _BOX_SPEEDS * math.sqrt(2.0 * e0 / float(m.min())) * req.dt * req.n_steps
    lo, hi = -4.0 * R - reach, 2.0 * R * n + 4.0 * R + reach
    y1, y2 = mp["youngsModulus"]
    model = "model hertz tangential no_history"
    lines = [
        "atom_style granular", "atom_modify map array",
        # f: a fixed box; a body that leaves it is lost and counted (_BOX_SPEEDS)
        "boundary f f f", "newton off", "communicate single vel yes", "units si",
        # Y > 1e9 Pa is refused in SI units without this (global_properties.cpp:370)
        "hard_particles yes",
        f"region reg block {lo!r} {hi!r} {-2 * R!r} {2 * R!r} {-2 * R!r} {2 * R!r} units box",
        "create_box 2 reg", f"neighbor {0.5 * R!r} bin", "neigh_modify delay 0",
        f"fix m1 all property/global youngsModulus peratomtype {y1!r} {y2!r}",
        "fix m2 all property/global poissonsRatio peratomtype 0.0 0.0",
        "fix m3 all property/global coefficientRestitution peratomtypepair 2 1.0 1.0 1.0 1.0",
        "fix m4 all property/global coefficientFriction peratomtypepair 2 0.0 0.0 0.0 0.0",
        "fix m5 all property/global characteristicVelocity scalar 1.0",
        f"pair_style gran {model}", "pair_coeff * *", f"timestep {req.dt!r}",
    ]  # fmt: skip
    for k, (plane, _side) in enumerate(req.wall_planes()):
        lines.append(f"fix w{k} all wall/gran {model} primitive type 2 xplane {plane!r}")
    for x in req.x0().tolist():
        lines.append(f"create_atoms 1 single {x!r} 0.0 0.0 units box")
    for i in range(n):
        lines += [
            f"set atom {i + 1} diameter {2.0 * R!r}",
            f"set atom {i + 1} density {mp['density'][i]!r}",
            f"set atom {i + 1} mass {mp['mass'][i]!r}",
        ]
    lines.append("velocity all set 0.0 0.0 0.0 units box")
    for i, v in enumerate(req.velocities):
        if v:
            lines.append(f"set atom {i + 1} vx {float(v)!r}")
    for i in range(n):
        lines += [f"variable x{i + 1} equal x[{i + 1}]", f"variable v{i + 1} equal vx[{i + 1}]"]
    lines += ["variable na equal count(all)", "fix int all nve/sphere", "thermo 0",
              "thermo_modify lost ignore"]  # fmt: skip
    return "\n".join(lines) + "\n"


def chain_script(req: ChainRequest, mp: dict) -> str:
    """The input script of one chain run: ``n_steps`` steps, one HCVC line after each."""
    n = req.n_bodies
    fields = "${na} " + " ".join(f"${{x{i + 1}}}" for i in range(n))
    fields += " " + " ".join(f"${{v{i + 1}}}" for i in range(n))
    return (
        _head(req, mp)
        + f'fix pr all print 1 "HCVC {fields}" screen yes title none\n'
        + f"run {int(req.n_steps)}\n"
    )


def chain_advice_script(req: ChainRequest, mp: dict) -> str:
    """The script that asks ``fix check/timestep/gran`` for its two times: one step."""
    f = _WARN_FRACTION
    return (
        _head(req, mp)
        + f"fix ct all check/timestep/gran 1 {f!r} {f!r}\n"
        + "variable fr equal f_ct[1]\nvariable fh equal f_ct[2]\n"
        + 'run 1\nprint "HCVADV ${fr} ${fh}"\n'
    )


def parse_chain(out: str, req: ChainRequest, meta: dict) -> ChainRun:
    """The ``HCVC`` lines of a run as a `ChainRun` (sample 0: the request's start).

    A sample after a body left the box (fewer than N atoms counted) is NaN: blown.
    """
    n = req.n_bodies
    rows = [ln.split()[1:] for ln in out.splitlines() if ln.startswith("HCVC ")]
    try:
        data = np.array(rows, dtype=float).reshape(len(rows), 1 + 2 * n)
    except ValueError:
        raise AdapterRunError("liggghts printed a malformed chain line", out[-4000:]) from None
    lost = np.flatnonzero(data[:, 0] < n)
    data = data[:, 1:]
    if lost.size:
        data[lost[0] :] = np.nan
        meta = {**meta, "lost_at_step": int(lost[0] + 1)}
    x = np.vstack([req.x0()[None, :], data[:, :n]])
    v = np.vstack([np.asarray(req.velocities, dtype=float)[None, :], data[:, n:]])
    return ChainRun(x, v, meta)


def parse_advice(out: str, dt: float) -> dict:
    """{"rayleigh": t_R, "hertz": t_H} (s) from the fractions dt / t that LIGGGHTS printed."""
    line = next((ln for ln in out.splitlines() if ln.startswith("HCVADV ")), None)
    if line is None:
        raise AdapterRunError("liggghts printed no check/timestep/gran fractions", out[-4000:])
    fr, fh = (float(s) for s in line.split()[1:3])
    # a fraction of 0 is a time LIGGGHTS found infinite (no speed for the Hertz time)
    return {
        "rayleigh": dt / fr if fr > 0 else math.inf,
        "hertz": dt / fh if fh > 0 else math.inf,
    }
