"""Assembly scenes: ``kind = "chain"`` and ``kind = "lattice"`` (section 6 where DEM lives).

A chain::

    kind = "chain"
    n = 10                       # bodies (>= 1)
    mass = 4.1103e-3             # kg, or a list of n masses
    walls = "both"               # "none" | "one" (right end) | "both"
    gap = 0.0                    # m, gap of each contact at the start (>= 0)
    velocities = 1.0             # m/s: the striker's (body 0) speed, or a list of n
    bonded = false               # springs that pull as well as push (gap must be 0)
    [potential]                  # the contact law between neighbours (any family)
    [damping]                    # optional: "none" or "universal"

A lattice::

    kind = "lattice"
    lattice = "fcc"              # square | triangular | honeycomb | simple-cubic | bcc | fcc
    cells = 3                    # conventional cells per direction (or a list)
    periodic = true              # else the bonds across the box end on walls
    mass = 4.1103e-3             # kg, every body
    radius = 5e-3                # m, every body (spacing 2 radius + gap)
    gap = 0.0
    velocities = 1.0             # m/s, the striker's (body 0) speed, or a list of n
    bonded = false
    tangential_ratio = 0.0       # k_t / k (bonded linear springs only)
    rotation = false             # integrate rotations (tangential springs turn bodies)

The bodies of a lattice move along a fixed direction that is no lattice direction
(`reference_impl.assembly.model`), at the striker's speed (body 0 only) or at one speed per body
(a list, which excites every mode, even one whose shape vanishes at the striker's site);
with ``rotation = true`` each also spins at its speed / R about the same axis. Every
problem is one line naming the scene and the key (`SceneError`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from reference_impl.assembly.geometry import LATTICES, MAX_BODIES, WALLS
from reference_impl.assembly.linear import linear_k
from reference_impl.scenes._fields import _keys, _number, _short, _string, _Where

__all__ = ["ASSEMBLY_KINDS", "AssemblyFields", "assembly_fields"]

ASSEMBLY_KINDS = ("chain", "lattice")
_COMMON = ("name", "kind", "mass", "gap", "velocities", "potential", "damping", "bonded")
_CHAIN_KEYS = (*_COMMON, "n", "walls")
_LATTICE_KEYS = (*_COMMON, "lattice", "cells", "periodic", "radius", "tangential_ratio", "rotation")


@dataclass(frozen=True)
class AssemblyFields:
    """What an assembly scene adds to a single-contact one (SI units).

    Attributes
    ----------
    n_bodies : int
        Number of bodies.
    masses : tuple of float
        Chain: each body's mass (kg); lattice: the one mass.
    walls : str or None
        Chain: ``"none"``, ``"one"`` or ``"both"``.
    lattice, cells, periodic, radius
        Lattice: its name, cells per direction, periodic box, body radius (m).
    body_velocities : tuple of float or None
        One initial speed per body (m/s; a chain's along the line, signed), or None (the
        striker's speed only).
    bonded : bool
        Springs that pull as well as push.
    tangential_ratio : float
        k_t / k (bonded linear springs only).
    rotation : bool
        Rotations integrated.
    """

    n_bodies: int
    masses: tuple
    walls: str | None = None
    lattice: str | None = None
    cells: tuple = ()
    periodic: bool = True
    radius: float = 0.0
    body_velocities: tuple | None = None
    bonded: bool = False
    tangential_ratio: float = 0.0
    rotation: bool = False
    extra: dict = field(default_factory=dict)

    def to_dict(self, kind: str, gap: float) -> dict[str, Any]:
        """The assembly's keys of the scene table (accepted back by the parser)."""
        out: dict[str, Any] = {"bonded": self.bonded, "gap": gap}
        if kind == "chain":
            out.update(n=self.n_bodies, walls=self.walls)
            out["mass"] = list(self.masses) if len(set(self.masses)) > 1 else self.masses[0]
            if self.body_velocities is not None:
                out["velocities"] = list(self.body_velocities)
        else:
            out.update(
                lattice=self.lattice,
                cells=list(self.cells),
                periodic=self.periodic,
                radius=self.radius,
                tangential_ratio=self.tangential_ratio,
                rotation=self.rotation,
                mass=self.masses[0],
            )
            if self.body_velocities is not None:
                out["velocities"] = list(self.body_velocities)
        return out


def _bool(err: _Where, data: dict, key: str, default: bool) -> bool:
    v = data.get(key, default)
    if not isinstance(v, bool):
        raise err(f"{key} must be true or false, got {_short(v)}")
    return v


def _count(err: _Where, value, name: str, low: int, high: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise err(f"{name} must be an integer in [{low}, {high}], got {_short(value)}")
    return int(value)


def assembly_fields(
    err: _Where, data: dict, kind: str, build_potential
) -> tuple[AssemblyFields, Any, float, float, float]:
    """(fields, potential, striker mass (kg), striker speed (m/s), gap (m)) of a scene table.

    ``build_potential(table)`` builds the ``[potential]`` table (the scene parser's, with
    its cache), called once the keys are known to be right.

    Raises
    ------
    SceneError
        One line naming the key and value (n < 1, an unknown lattice, a negative gap:
        bodies or walls overlapping at the start, NaN, a list of the wrong length, ...).
    """
    allowed = _CHAIN_KEYS if kind == "chain" else _LATTICE_KEYS
    required = ("mass", "velocities", "potential")
    required += ("n",) if kind == "chain" else ("lattice", "cells", "radius")
    _keys(err, data, "", allowed, required)
    pot = build_potential(data["potential"])
    gap = float(data.get("gap", 0.0))
    if "gap" in data:
        gap = _number(err, data["gap"], "gap", low=-math.inf)
        if gap < 0.0:
            raise err(
                f"gap = {gap!r} m < 0: the bodies (and walls) would overlap at the start; "
                "give a gap >= 0"
            )
    bonded = _bool(err, data, "bonded", False)
    if bonded and gap != 0.0:
        raise err(f"bonded springs are at rest at the start: gap must be 0, got {gap!r}")
    if kind == "chain":
        fields, v0 = _chain_fields(err, data, bonded)
    else:
        fields, v0 = _lattice_fields(err, data, bonded, pot)
    return fields, pot, fields.masses[0], v0, gap


def _chain_fields(err: _Where, data: dict, bonded: bool) -> tuple[AssemblyFields, float]:
    n = data["n"]
    if isinstance(n, int) and not isinstance(n, bool) and n < 1:
        raise err(f"n = {n!r}: a chain needs at least one body (n >= 1)")
    n = _count(err, n, "n", 1, MAX_BODIES)
    walls = _string(err, data.get("walls", "none"), "walls", WALLS)
    masses = _numbers(err, data["mass"], "mass", n, positive=True)
    body_v, v0 = _velocities(err, data["velocities"], n)
    fields = AssemblyFields(
        n_bodies=n, masses=masses, walls=walls, body_velocities=body_v, bonded=bonded
    )
    return fields, v0


def _velocities(err: _Where, vel, n: int) -> tuple[tuple | None, float]:
    """(per-body speeds or None, the striker's speed (m/s)) of ``velocities``."""
    if isinstance(vel, list):
        body_v = _numbers(err, vel, "velocities", n, positive=False)
        if not any(body_v):
            raise err("velocities are all 0: nothing moves; give the striker a speed")
        return body_v, max(abs(v) for v in body_v)
    return None, _number(err, vel, "velocities", low=0.0)


def _numbers(err: _Where, value, name: str, n: int, positive: bool) -> tuple:
    """A number repeated n times, or a list of exactly n numbers (each > 0 if positive)."""
    low = 0.0 if positive else -math.inf
    if isinstance(value, list):
        if len(value) != n:
            raise err(f"{name} has {len(value)} entries; give one number or n = {n} of them")
        return tuple(_number(err, v, f"{name}[{i}]", low=low) for i, v in enumerate(value))
    return (_number(err, value, name, low=low),) * n


def _lattice_fields(err: _Where, data: dict, bonded: bool, pot) -> tuple[AssemblyFields, float]:
    name = _string(err, data["lattice"], "lattice", LATTICES)
    dim = 2 if name in ("square", "triangular", "honeycomb") else 3
    periodic = _bool(err, data, "periodic", True)
    low = 2 if periodic else 1
    raw = data["cells"]
    cells = tuple(
        _count(err, c, f"cells[{i}]" if isinstance(raw, list) else "cells", low, 1000)
        for i, c in enumerate(raw if isinstance(raw, list) else [raw] * dim)
    )
    if len(cells) != dim:
        raise err(f"cells has {len(cells)} entries; the {name} lattice has {dim} directions")
    mass = _number(err, data["mass"], "mass", low=0.0)
    radius = _number(err, data["radius"], "radius", low=0.0)
    ratio = _number(
        err, data.get("tangential_ratio", 0.0), "tangential_ratio", low=0.0, strict=False
    )
    rotation = _bool(err, data, "rotation", False)
    if ratio > 0.0 and (not bonded or linear_k(pot) is None):
        raise err(
            f"tangential_ratio = {ratio!r}: tangential springs are modelled for bonded linear "
            "springs only (bonded = true, family 'power' with p = 1)"
        )
    n = len(_basis_count(name)) * math.prod(cells)
    if n > MAX_BODIES:
        raise err(f"lattice {name!r} with cells {list(cells)} has {n} bodies; at most {MAX_BODIES}")
    body_v, v0 = _velocities(err, data["velocities"], n)
    fields = AssemblyFields(
        n_bodies=n,
        masses=(mass,),
        body_velocities=body_v,
        lattice=name,
        cells=cells,
        periodic=periodic,
        radius=radius,
        bonded=bonded,
        tangential_ratio=ratio,
        rotation=rotation,
    )
    return fields, v0


def _basis_count(name: str) -> tuple:
    """The basis sites of a lattice's conventional cell (one entry each)."""
    return {"honeycomb": (0, 1), "bcc": (0, 1), "fcc": (0, 1, 2, 3)}.get(name, (0,))
