"""The contact network of an assembly: chains and lattices as bodies, contacts and normals.

Body i sits at its site (of the chain or lattice) plus the displacement u_i. Contact c
joins bodies i and j (j = -1: a fixed wall); n_c is the unit vector from i to j along
their line of centres in the reference configuration, L_c their distance there (m) and
off_c the overlap at the sites (-gap). Two models of the overlap are run:

* following the line of centres (finite displacements, what LIGGGHTS, LAMMPS and YADE
  run): q_c = R_i + R_j - |L_c n_c + u_j - u_i|, the force along the current unit vector
  from i to j. A bond across a periodic box keeps the image it has at the sites (the
  vector L_c n_c), which is the codes' minimum image while no pair's separation changes
  by half a box. The default of a lattice (`overlaps`, the kernel's ``length`` argument);
* fixed normals (small displacements about the sites): q_c = off_c + (u_i - u_j) . n_c,
  the force along n_c. The linearisation of the first about the sites, so the model of
  bonded springs, whose linear theory (`reference_impl.assembly.linear`) is a statement
  about small displacements, and of tangential springs (below).

A wall keeps its normal in both (a plane at a fixed place: its overlap is off_c + u_i . n_c
exactly), and so does a chain: its lines of centres are the x axis and cannot turn, so
the two models are the same and the chain runs the fixed-normal one (``length`` 0), bit
for bit as before. In a 2-D or 3-D lattice the line of centres turns as bodies move
sideways, by ~7e-3 rad within a few hundred steps at the 1 m/s of `lattice-hertz`, which
changes the forces at the per-cent level: there only the first model is what the codes
run (`verification/test_assembly_codes_lattice.py`: the kernel's positions are theirs to
1e-16 m over 300 steps).

Both models keep the contact list of the sites: no contact is ever made anew, where the
codes' neighbour lists would make one. That is the packing's while every body stays within
`Assembly.cage` of the mean displacement (no pair outside the list can then touch, and no
bond's image changes); a touching square or honeycomb layer without confining pressure
comes apart at 1 m/s and leaves it within ~1e3 steps, a close-packed layer does not
(`reference_impl.assembly.lanes.cage_fraction` measures it along a run).

Where tangential springs are asked (bonded linear springs only, so fixed normals), the
tangential displacement of the contact point is

    delta_t = P_t [(u_j - u_i) - (R_i theta_i + R_j theta_j) x n_c],

P_t the projection off n_c, theta the small rotations (one angle in 2-D, a vector in
3-D), spring force k_t delta_t; rotations are integrated only with ``rotation = true``.
With ``bonded`` springs and a linear law this is exactly the linear lattice whose
stiffness matrix `reference_impl.assembly.linear` assembles.

Walls: a chain's walls stand at its ends (``"one"``: the right end, which the striker's
pulse meets); a walled lattice replaces every bond that crosses the periodic box by a
contact with a fixed wall along the same bond direction (clamped boundary).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from reference_impl.errors import HCVInputError

__all__ = [
    "LATTICES", "WALLS", "Assembly", "chain", "coordination", "lattice", "lattice_sites",
    "overlaps",
]  # fmt: skip

WALLS = ("none", "one", "both")
# name -> (dimension, conventional cell vectors in units of the nearest-neighbour
# distance (rows), basis sites in fractional coordinates of that cell)
_S3 = math.sqrt(3.0)
_LATTICE_CELLS: dict[str, tuple[int, np.ndarray, np.ndarray]] = {
    "square": (2, np.eye(2), np.zeros((1, 2))),
    "triangular": (2, np.array([[1.0, 0.0], [0.5, _S3 / 2]]), np.zeros((1, 2))),
    # honeycomb: triangular Bravais lattice of spacing sqrt(3), two sites a distance 1 apart
    "honeycomb": (
        2,
        np.array([[_S3, 0.0], [_S3 / 2, 1.5]]),
        np.array([[0.0, 0.0], [1.0 / 3.0, 1.0 / 3.0]]),
    ),
    "simple-cubic": (3, np.eye(3), np.zeros((1, 3))),
    "bcc": (3, np.eye(3) * 2.0 / _S3, np.array([[0.0, 0.0, 0.0], [0.5, 0.5, 0.5]])),
    "fcc": (
        3,
        np.eye(3) * math.sqrt(2.0),
        np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]], dtype=float),
    ),
}
LATTICES = tuple(_LATTICE_CELLS)
# The coordination number Z of each periodic lattice (a test counts it from the bonds).
_Z = {"square": 4, "triangular": 6, "honeycomb": 3, "simple-cubic": 6, "bcc": 8, "fcc": 12}
# Bodies of one assembly: every step visits every contact of every lane, so a scene's
# size is bounded before any work (1e4 bodies, ~6e4 contacts, ~1 ms a step per lane).
MAX_BODIES = 10_000
# Relative tolerance on the nearest-neighbour distance when bonds are found: the cell
# vectors are products of sqrt(2), sqrt(3), so distances carry a few ulps of round-off.
_NN_RTOL = 1e-9
# Moment of inertia of a solid sphere, I = (2/5) m R^2 (the bodies are spheres in 2-D too).
_SPHERE_INERTIA = 0.4


@dataclass(frozen=True)
class Assembly:
    """Bodies and contacts of a chain or lattice (SI units).

    Attributes
    ----------
    dim : int
        Dimension of the displacements (1, 2 or 3).
    mass : numpy.ndarray
        Body masses (kg), shape (n,).
    radius : float
        Body radius R (m); the lever arm of tangential forces (0 when none are asked).
    ci, cj : numpy.ndarray
        Contact c joins body ci[c] and body cj[c] (int64; -1 is a fixed wall).
    normal : numpy.ndarray
        Unit vector from ci to cj in the reference configuration, shape (n_contacts, dim).
    off : numpy.ndarray
        Overlap of each contact at the sites (m): -gap.
    u0 : numpy.ndarray
        Displacement of each body from its site at the start (m), shape (n, dim).
    tangential_ratio : float
        k_t / k of the tangential springs (0: none), k the stiffness of the normal
        springs (bonded linear springs only).
    rotation : bool
        Rotations integrated (tangential springs turn the bodies).
    length : numpy.ndarray or None
        Distance L_c between the centres of ci and cj at the sites (m), > 0 where the
        contact can follow its line of centres, 0 where its normal is fixed (a wall); None
        (a chain) for every normal fixed.
    cage : float
        Largest distance (m) a body may move from its site, relative to the bodies' mean
        displacement, while no pair outside the contact list can touch: (d_2 - 2 R) / 2,
        d_2 the distance of second neighbours (two bodies that both moved less are closer
        than d_2 by less than d_2 - 2 R). Beyond it the fixed contact list (no contact is
        ever made anew) is no longer the packing's, as it is in the codes (neighbour lists).
        inf for a chain (a body meets no one but its neighbours in 1-D).
    coordination : float
        Mean number of contacts per body, walls counted (Z).
    """

    dim: int
    mass: np.ndarray
    radius: float
    ci: np.ndarray
    cj: np.ndarray
    normal: np.ndarray
    off: np.ndarray
    u0: np.ndarray
    tangential_ratio: float = 0.0
    rotation: bool = False
    length: np.ndarray | None = None
    cage: float = math.inf

    @property
    def n_bodies(self) -> int:
        """Number of bodies."""
        return int(self.mass.size)

    @property
    def n_contacts(self) -> int:
        """Number of contacts (walls included)."""
        return int(self.ci.size)

    @property
    def rot_dim(self) -> int:
        """Rotational degrees of freedom per body: 0, 1 (2-D) or 3 (3-D)."""
        if not self.rotation:
            return 0
        return 1 if self.dim == 2 else 3

    @property
    def inertia(self) -> np.ndarray:
        """Moments of inertia (2/5) m R^2 (kg m^2), shape (n,)."""
        return _SPHERE_INERTIA * self.mass * self.radius**2

    @property
    def coordination(self) -> float:
        """Mean contacts per body, a wall contact counted once for its body (Z)."""
        ends = np.count_nonzero(self.ci >= 0) + np.count_nonzero(self.cj >= 0)
        return float(ends) / self.n_bodies


def coordination(name: str) -> int:
    """The coordination number Z of the periodic lattice ``name``."""
    _check_name(name)
    return _Z[name]


def _check_name(name: str) -> None:
    if name not in _LATTICE_CELLS:
        raise HCVInputError(f"lattice {name!r} is not one of {', '.join(map(repr, LATTICES))}")


def chain(masses, walls: str = "none", gap: float = 0.0) -> Assembly:
    """A chain of bodies on a line, neighbours in contact, walls at its ends.

    Every contact has the gap ``gap`` at the start but the striker's (body 0): it starts
    at the onset of its contact with body 1 (or, alone, with the right wall), a gap
    ``gap`` to its left. Internally its site is at the onset of its left contact and it
    starts displaced by ``gap``: for one body between two walls the overlaps are then
    computed as the single-contact lanes compute them (``-y`` and ``y - gap``), bit for bit.

    Parameters
    ----------
    masses : sequence of float
        Body masses (kg), left to right; at least one.
    walls : {"none", "one", "both"}
        Fixed walls: none, at the right end (the striker's pulse meets it), or at both ends.
    gap : float
        The gap of each contact at the start (m, >= 0); 0 for bonded springs.
    """
    m = np.asarray(masses, dtype=float).ravel()
    n = m.size
    if n < 1 or n > MAX_BODIES:
        raise HCVInputError(f"a chain needs 1 to {MAX_BODIES} bodies, got n = {n}")
    if walls not in WALLS:
        raise HCVInputError(f"walls {walls!r} is not one of {', '.join(map(repr, WALLS))}")
    g = float(gap)
    ci, cj, nx, off = [], [], [], []
    if walls == "both":  # left wall (j = -1), normal from body 0 to it; the striker's site
        ci.append(0)  # is at its onset
        cj.append(-1)
        nx.append(-1.0)
        off.append(0.0)
    for i in range(n - 1):
        ci.append(i)
        cj.append(i + 1)
        nx.append(1.0)
        off.append(-g)
    if walls in ("one", "both"):
        ci.append(n - 1)
        cj.append(-1)
        nx.append(1.0)
        off.append(-g)
    k = len(ci)
    u0 = np.zeros((n, 1))
    u0[0, 0] = g
    return Assembly(
        dim=1,
        mass=m,
        radius=0.0,
        ci=np.array(ci, dtype=np.int64),
        cj=np.array(cj, dtype=np.int64),
        normal=np.array(nx, dtype=float).reshape(k, 1),
        off=np.array(off, dtype=float),
        u0=u0,
    )


def _second_distance(name: str) -> float:
    """Distance of second neighbours (units of the nearest-neighbour distance)."""
    dim, cell, basis = _LATTICE_CELLS[name]
    ds = []
    for s, t in itertools.product(range(len(basis)), repeat=2):
        for o in itertools.product((-2, -1, 0, 1, 2), repeat=dim):
            d = float(np.linalg.norm((np.array(o, dtype=float) + basis[t] - basis[s]) @ cell))
            if d > 1.0 + _NN_RTOL:
                ds.append(d)
    return min(ds)


def _bond_offsets(name: str) -> list[tuple[int, int, tuple[int, ...], np.ndarray]]:
    """(basis s, basis t, cell offset o, unit vector) of every nearest-neighbour bond, each once."""
    dim, cell, basis = _LATTICE_CELLS[name]
    cands = []
    for s, t in itertools.product(range(len(basis)), repeat=2):
        for o in itertools.product((-1, 0, 1), repeat=dim):
            vec = (np.array(o, dtype=float) + basis[t] - basis[s]) @ cell
            d = float(np.linalg.norm(vec))
            if d > 0:
                cands.append((s, t, o, vec, d))
    nn = min(c[4] for c in cands)
    out = []
    for s, t, o, vec, d in cands:
        if abs(d - nn) > _NN_RTOL * nn:
            continue
        zero = (0,) * dim
        if o > zero or (o == zero and t > s):  # one of the pair (s, t, o) and (t, s, -o)
            out.append((s, t, o, vec / d))
    return out


def lattice(
    name: str,
    cells,
    mass: float,
    radius: float,
    *,
    periodic: bool = True,
    gap: float = 0.0,
    tangential_ratio: float = 0.0,
    rotation: bool = False,
) -> Assembly:
    """A lattice of touching spheres (nearest neighbours in contact).

    Parameters
    ----------
    name : str
        One of `LATTICES`.
    cells : int or sequence of int
        Conventional cells along each lattice vector (>= 2 when periodic, so that no body
        is its own neighbour).
    mass, radius : float
        Mass (kg) and radius (m) of every body; the nearest-neighbour distance is 2 R + gap.
    periodic : bool
        Periodic box, else the bonds across it end on fixed walls.
    gap : float
        Gap of every contact at the sites (m, >= 0).
    tangential_ratio : float
        k_t / k_n of tangential springs (0: none).
    rotation : bool
        Integrate rotations (needs tangential springs to matter).
    """
    _check_name(name)
    dim, _, basis = _LATTICE_CELLS[name]
    cells_t = (int(cells),) * dim if np.isscalar(cells) else tuple(int(c) for c in cells)
    low = 2 if periodic else 1
    if len(cells_t) != dim or min(cells_t) < low:
        raise HCVInputError(
            f"lattice {name!r} needs cells >= {low} along each of its {dim} directions "
            f"({'periodic' if periodic else 'walled'}), got {cells!r}"
        )
    nb = len(basis)
    n = nb * math.prod(cells_t)
    if n > MAX_BODIES:
        raise HCVInputError(
            f"lattice {name!r} with cells {cells!r} has {n} bodies; at most {MAX_BODIES}"
        )
    index = {}
    for k, c in enumerate(itertools.product(*(range(c) for c in cells_t))):
        for s in range(nb):
            index[(c, s)] = k * nb + s
    ci, cj, normals = [], [], []
    bonds = _bond_offsets(name)
    spacing = 2.0 * float(radius) + float(gap)  # L_c of every bond between two bodies
    for c in itertools.product(*(range(m) for m in cells_t)):
        for s, t, o, unit in bonds:
            tgt = tuple(a + b for a, b in zip(c, o, strict=False))
            if all(0 <= r < m for r, m in zip(tgt, cells_t, strict=False)) or periodic:
                ci.append(index[(c, s)])
                cj.append(index[(tuple(r % m for r, m in zip(tgt, cells_t, strict=False)), t)])
                normals.append(unit)
                continue
            # walled: the bond leaves the box at its target, so the source meets a wall
            # along it; the same bond entering the box from outside gives its target the
            # mirror wall (source cell c - o, target (c, t)).
            ci.append(index[(c, s)])
            cj.append(-1)
            normals.append(unit)
        if not periodic:
            for _s, t, o, unit in bonds:
                src = tuple(a - b for a, b in zip(c, o, strict=False))
                if not all(0 <= r < m for r, m in zip(src, cells_t, strict=False)):
                    ci.append(index[(c, t)])
                    cj.append(-1)
                    normals.append(-unit)
    k = len(ci)
    return Assembly(
        dim=dim,
        mass=np.full(n, float(mass)),
        radius=float(radius),
        ci=np.array(ci, dtype=np.int64),
        cj=np.array(cj, dtype=np.int64),
        normal=np.array(normals, dtype=float).reshape(k, dim),
        off=np.full(k, -float(gap)),
        u0=np.zeros((n, dim)),
        tangential_ratio=float(tangential_ratio),
        rotation=bool(rotation),
        length=np.where(np.array(cj, dtype=np.int64) >= 0, spacing, 0.0),
        cage=0.5 * (_second_distance(name) * spacing - 2.0 * float(radius)),
    )


def lattice_sites(name: str, cells, spacing: float) -> tuple[np.ndarray, np.ndarray | None]:
    """Sites of the bodies of `lattice` (same order) and its periodic box, for the codes.

    Parameters
    ----------
    name : str
        One of `LATTICES`.
    cells : int or sequence of int
        Conventional cells along each lattice vector.
    spacing : float
        Nearest-neighbour distance (m), 2 R + gap.

    Returns
    -------
    sites : numpy.ndarray
        Shape (n, dim), in m, body k = cell index * basis size + basis index as `lattice`
        numbers them, inside [0, box) along each axis.
    box : numpy.ndarray or None
        Edge lengths (m) of the periodic box, shape (dim,), when the conventional cell is
        rectangular (square, simple-cubic, bcc, fcc); None for a skewed cell (triangular,
        honeycomb), whose periodic box is no rectangle.
    """
    _check_name(name)
    dim, cell, basis = _LATTICE_CELLS[name]
    cells_t = (int(cells),) * dim if np.isscalar(cells) else tuple(int(c) for c in cells)
    frac = [np.array(c, dtype=float) + b for c in itertools.product(*(range(m) for m in cells_t))
            for b in basis]  # fmt: skip
    sites = float(spacing) * (np.array(frac).reshape(-1, dim) @ cell)
    rect = np.allclose(cell, np.diag(np.diag(cell)), rtol=0.0, atol=0.0)
    box = float(spacing) * np.diag(cell) * np.array(cells_t, dtype=float) if rect else None
    return sites, box


def overlaps(asm: Assembly, u: np.ndarray, follow: bool) -> np.ndarray:
    """Overlap q_c (m) of every contact at displacements ``u`` (m, shape (n, dim)).

    ``follow``: along the line of centres where ``asm.length`` > 0 (the module's first
    model), else every normal fixed (its second). The kernel computes the same overlaps
    (`reference_impl.integrators.assembly_kernel`); this is their numpy form, for the
    initial energy.
    """
    uj = np.where(asm.cj[:, None] >= 0, u[np.maximum(asm.cj, 0)], 0.0)
    q = asm.off + np.sum((u[asm.ci] - uj) * asm.normal, axis=1)
    if follow and asm.length is not None:
        lc = asm.length
        du = uj - u[asm.ci]
        sep = np.sqrt(np.sum((lc[:, None] * asm.normal + du) ** 2, axis=1))
        # L - |L n + du| = -(2 L n.du + du.du) / (L + |L n + du|): no cancellation
        num = 2.0 * lc * np.sum(du * asm.normal, axis=1) + np.sum(du * du, axis=1)
        along = asm.off - num / np.where(lc > 0.0, lc + sep, 1.0)  # walls: 0 / 1, not 0 / 0
        q = np.where(lc > 0.0, along, q)
    return q
