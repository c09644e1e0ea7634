"""LIGGGHTS input decks of the assembly runs (contract item 14): what a chain and a lattice share.

A chain (`reference_impl.adapters._liggghts_chain`) and a periodic lattice
(`reference_impl.adapters._liggghts_lattice`) are the same deck with another box, other
sites and other printed fields: granular atoms of one radius, normal Hertz only
(``pair_style gran model hertz tangential no_history``: no tangential force, no torque),
restitution 1 (the Hertz model's dashpot is zero: log e = 0), no friction, no gravity,
``fix nve/sphere``, one ``fix print`` line after every step. This module writes that deck
and reads back what it prints; each geometry writes only its box, walls, sites and fields.

Hertz in LIGGGHTS 3.8.0 (``normal_model_hertz.h``, see `reference_impl.adapters.liggghts`):
U' = 4/3 Y_eff sqrt(R_eff) q^(3/2) with R_eff = R/2 between two spheres,
1/Y_eff = (1 - nu_a^2)/Y_a + (1 - nu_b^2)/Y_b (``global_properties.cpp``). With nu = 0,
the spheres' Young modulus Y = 2 (3/4) k / sqrt(R/2) gives the scene's k between two
spheres. Each sphere's density is m_i / (4/3 pi R^3), so that the step advice, which reads
the density, sees the scene's bodies; its mass is then set to m_i exactly.

Step advice: ``fix check/timestep/gran 1 f_r f_h`` computes the Rayleigh time and the
Hertz time (the latter from the largest particle speed of the current step) and gives
dt / t_Rayleigh and dt / t_Hertz as ``f_ID[1]``, ``f_ID[2]``; the deck runs one step and
prints them (``fix_check_timestep_gran.cpp``): the times are dt over those fractions, as
LIGGGHTS computed them, nothing retyped.
"""

from __future__ import annotations

import math

import numpy as np

from reference_impl.adapters._records import AdapterDeclined, AdapterRunError

__all__ = ["MODEL", "advice_script", "deck", "hertz_mapping", "parse_advice", "read_rows",
           "run_script"]  # fmt: skip

# The granular model of every pair and wall: normal Hertz, no tangential force.
MODEL = "model hertz tangential no_history"
# The fractions LIGGGHTS warns at (fix check/timestep/gran's own arguments): they only
# choose when it prints a warning, never the times it computes; 1 keeps the output short.
_WARN_FRACTION = 1.0
# The tail of LIGGGHTS' output an error carries: the last lines say what went wrong.
_TAIL = 4000


def hertz_mapping(req, what: str) -> dict:
    """LIGGGHTS inputs of an assembly's spheres: Y, nu, densities, masses (SI units).

    Parameters
    ----------
    req : ChainRequest or LatticeRequest
        The assembly (its potential, radius R in m and masses in kg).
    what : str
        ``"chains"`` or ``"lattices"``, for the decline.

    Returns
    -------
    dict
        ``model``, ``R`` (m), ``youngsModulus`` of the spheres (Pa), ``poissonsRatio`` 0,
        ``density`` (kg/m^3) and ``mass`` (kg) of each body.

    Raises
    ------
    AdapterDeclined
        The law is not Hertz (LIGGGHTS' ``model hertz`` is U' = k q^(3/2)).
    """
    pot = req.potential
    if type(pot).__name__ != "PowerLaw" or getattr(pot, "p", None) != 1.5:
        raise AdapterDeclined(f"liggghts runs Hertz {what} only (power law, p = 1.5), "
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


def _materials(youngs: list[float]) -> list[str]:
    """The property/global lines of atom types 1.. len(youngs) (Y in Pa, nu 0, e 1, mu 0)."""
    n = len(youngs)
    pairs = n * n
    return [
        "fix m1 all property/global youngsModulus peratomtype "
        + " ".join(repr(float(y)) for y in youngs),
        "fix m2 all property/global poissonsRatio peratomtype " + " ".join(["0.0"] * n),
        f"fix m3 all property/global coefficientRestitution peratomtypepair {n} "
        + " ".join(["1.0"] * pairs),
        f"fix m4 all property/global coefficientFriction peratomtypepair {n} "
        + " ".join(["0.0"] * pairs),
        "fix m5 all property/global characteristicVelocity scalar 1.0",
    ]


def deck(req, mp: dict, *, boundary: str, region: str, youngs: list[float], walls: list[str],
         sites, velocities: list[str], variables: list[str]) -> str:  # fmt: skip
    """Everything of an assembly's script up to the run: box, materials, bodies, variables.

    Parameters
    ----------
    req : ChainRequest or LatticeRequest
        The assembly (radius R in m, step dt in s, bodies).
    mp : dict
        Its `hertz_mapping` (densities, masses).
    boundary : str
        LIGGGHTS' ``boundary`` of x, y, z (``"f f f"``, ``"p p p"``, ...).
    region : str
        The box's ``region reg block ...`` line (m).
    youngs : list of float
        Young modulus of each atom type (Pa): the spheres' first, a wall's after.
    walls : list of str
        Wall fixes, after the time step.
    sites : iterable of (float, float, float)
        Initial centres (m), one atom of type 1 each.
    velocities : list of str
        ``set atom`` lines of the non-zero initial velocities.
    variables : list of str
        The ``variable`` lines the printed fields read.

    Returns
    -------
    str
        The script's lines; its variable ``na`` counts the atoms left (one that leaves a
        fixed box is lost, not an error: ``thermo_modify lost ignore``; `read_rows` marks
        the samples from it on as blown).
    """
    R = req.radius
    lines = [
        "atom_style granular", "atom_modify map array", f"boundary {boundary}", "newton off",
        "communicate single vel yes", "units si",
        # Y > 1e9 Pa is refused in SI units without this (global_properties.cpp:370)
        "hard_particles yes",
        region, f"create_box {len(youngs)} reg", f"neighbor {0.5 * R!r} bin",
        "neigh_modify delay 0",
        *_materials(youngs),
        f"pair_style gran {MODEL}", "pair_coeff * *", f"timestep {req.dt!r}",
        *walls,
    ]  # fmt: skip
    for x, y, z in sites:
        lines.append(f"create_atoms 1 single {x!r} {y!r} {z!r} units box")
    for i in range(req.n_bodies):
        lines += [
            f"set atom {i + 1} diameter {2.0 * R!r}",
            f"set atom {i + 1} density {mp['density'][i]!r}",
            f"set atom {i + 1} mass {mp['mass'][i]!r}",
        ]
    lines.append("velocity all set 0.0 0.0 0.0 units box")
    lines += velocities
    lines += variables
    lines += ["variable na equal count(all)", "fix int all nve/sphere", "thermo 0",
              "thermo_modify lost ignore"]  # fmt: skip
    return "\n".join(lines) + "\n"


def run_script(head: str, tag: str, fields: str, n_steps: int) -> str:
    """The input script of one run: ``n_steps`` steps, one ``tag ${na} fields`` line after each."""
    return (
        head
        + f'fix pr all print 1 "{tag} ${{na}} {fields}" screen yes title none\n'
        + f"run {int(n_steps)}\n"
    )


def advice_script(head: str) -> str:
    """The script that asks ``fix check/timestep/gran`` for its two times: one step."""
    f = _WARN_FRACTION
    return (
        head
        + f"fix ct all check/timestep/gran 1 {f!r} {f!r}\n"
        + "variable fr equal f_ct[1]\nvariable fh equal f_ct[2]\n"
        + 'run 1\nprint "HCVADV ${fr} ${fh}"\n'
    )


def read_rows(out: str, tag: str, n: int, width: int, kind: str, meta: dict):
    """The ``tag`` lines of a run's output as numbers, NaN from the first sample with a lost body.

    Parameters
    ----------
    out : str
        LIGGGHTS' output.
    tag : str
        The lines' first word (``HCVC``, ``HCVL``).
    n : int
        Number of bodies; a line whose count ``${na}`` is below it has lost one.
    width : int
        Numbers of a line after the count.
    kind : str
        ``"chain"`` or ``"lattice"``, for the error.
    meta : dict
        The run's meta.

    Returns
    -------
    data : numpy.ndarray
        Shape (lines, width); every sample from a lost body's on is NaN (blown).
    meta : dict
        ``meta``, with ``lost_at_step`` (1-based) where a body was lost.

    Raises
    ------
    AdapterRunError
        A line with other than 1 + width numbers.
    """
    rows = [ln.split()[1:] for ln in out.splitlines() if ln.startswith(tag + " ")]
    try:
        data = np.array(rows, dtype=float).reshape(len(rows), 1 + width)
    except ValueError:
        raise AdapterRunError(f"liggghts printed a malformed {kind} line", out[-_TAIL:]) from None
    lost = np.flatnonzero(data[:, 0] < n)
    data = data[:, 1:]
    if lost.size:
        data[lost[0] :] = np.nan
        meta = {**meta, "lost_at_step": int(lost[0] + 1)}
    return data, meta


def parse_advice(out: str, dt: float) -> dict:
    """{"rayleigh": t_R, "hertz": t_H} (s) from the fractions dt / t that LIGGGHTS printed."""
    line = next((ln for ln in out.splitlines() if ln.startswith("HCVADV ")), None)
    if line is None:
        raise AdapterRunError("liggghts printed no check/timestep/gran fractions", out[-_TAIL:])
    fr, fh = (float(s) for s in line.split()[1:3])
    # a fraction of 0 is a time LIGGGHTS found infinite (no speed for the Hertz time)
    return {
        "rayleigh": dt / fr if fr > 0 else math.inf,
        "hertz": dt / fh if fh > 0 else math.inf,
    }
