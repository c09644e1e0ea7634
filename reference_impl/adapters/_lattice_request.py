"""The lattice request of the adapter contract (item 14 in `reference_impl.adapters.base`).

A periodic lattice of touching spheres handed to a code: the bodies' 3-D positions inside a
rectangular box, their radius, masses and initial velocities, the box's edges and which of
its axes are periodic, and the contact list (pairs of bodies and the periodic shift that
joins them at the start). A 2-D lattice is a layer of spheres in one plane z = z_0 of a
3-D code: its z axis is not periodic, every centre has z = z_0 and no velocity along z, so
every line of centres and every force lies in the plane and z stays z_0 by construction. Normal contacts
only, with the scene's law U(q), q = 2 R - |x_j + s - x_i| the overlap of a listed pair
along the actual line of centres (no tangential springs, no rotation: the codes' requests
decline a scene that asks them). The code runs it at one step for a number of steps and
returns every body's position and velocity after every step (`LatticeRun`); as for a
chain (`reference_impl.adapters._assembly_request`) the suite computes the energy with the
scene's own law and decides a runaway with its own rule.

Positions a code returns may be wrapped into the box; `lattice_run_from_mapping` unwraps
them by continuity from the start (a body moves by less than half a box edge in one step
until a run has blown up, which the energy then shows).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from reference_impl.adapters._assembly_request import MAX_CODE_STEPS, _checked_states
from reference_impl.errors import HCVInputError
from reference_impl.potentials.base import Potential

__all__ = ["LatticeRequest", "LatticeRun", "lattice_energy", "lattice_run_from_mapping"]

# Relative tolerance on each listed contact's length 2 R at the start: the sites are sums
# of products of sqrt(2), sqrt(3) and R, a few ulps of round-off.
_BOND_RTOL = 1e-9


@dataclass(frozen=True, eq=False)
class LatticeRequest:
    """A periodic lattice of spheres for a contact code (contract item 14). SI units.

    Attributes
    ----------
    name : str
        The scene's name.
    potential : Potential
        The normal law U(q) of every contact (a code maps it to its own inputs).
    masses : tuple of float
        Body masses (kg).
    radius : float
        Sphere radius R (m).
    positions, velocities : numpy.ndarray
        Initial centres (m, inside [0, box)) and velocities (m/s), shape (N, 3).
    box : tuple of float
        Edges of the box [0, Lx) x [0, Ly) x [0, Lz) (m).
    periodic : tuple of bool
        Periodic axes; a 2-D layer has (True, True, False), one z and no z velocity.
    contacts : numpy.ndarray
        Pairs (i, j) of bodies in contact at the start, int, shape (C, 2).
    shifts : numpy.ndarray
        Periodic shift s of each pair (m), shape (C, 3): x_j + s - x_i is their line of
        centres, of length 2 R at the start.
    dt : float
        The time step (s).
    n_steps : int
        Steps to run (the code returns n_steps + 1 samples, the first the start).
    stop_energy : float
        The code may end the run after the first step whose kinetic energy exceeds this
        (J), as for a chain (`ChainRequest.stop_energy`).
    """

    name: str
    potential: Potential
    masses: tuple
    radius: float
    positions: np.ndarray
    velocities: np.ndarray
    box: tuple
    periodic: tuple
    contacts: np.ndarray
    shifts: np.ndarray
    dt: float
    n_steps: int
    stop_energy: float = math.inf

    def __post_init__(self):
        who = f"lattice request {self.name!r}"
        n = len(self.masses)
        if n < 1 or not all(math.isfinite(m) and m > 0 for m in self.masses):
            raise HCVInputError(f"{who}: masses must be >= 1 value > 0 (kg), got {n}")
        if not (math.isfinite(self.radius) and self.radius > 0):
            raise HCVInputError(f"{who}: radius must be > 0 (m), got {self.radius!r}")
        for key in ("positions", "velocities"):
            a = np.asarray(getattr(self, key), dtype=float)
            if a.shape != (n, 3) or not np.all(np.isfinite(a)):
                raise HCVInputError(f"{who}: {key} must be {n} finite rows of 3, "
                                    f"got shape {a.shape}")  # fmt: skip
            object.__setattr__(self, key, a)
        box = tuple(float(b) for b in self.box)
        if len(box) != 3 or not all(math.isfinite(b) and b > 0 for b in box):
            raise HCVInputError(f"{who}: box must be 3 edges > 0 (m), got {self.box!r}")
        object.__setattr__(self, "box", box)
        if len(self.periodic) != 3:
            raise HCVInputError(f"{who}: periodic must name 3 axes, got {self.periodic!r}")
        object.__setattr__(self, "periodic", tuple(bool(p) for p in self.periodic))
        if np.any(self.positions < 0) or np.any(self.positions >= np.array(box)):
            raise HCVInputError(f"{who}: positions must lie in the box [0, {box})")
        c = np.asarray(self.contacts, dtype=np.int64).reshape(-1, 2)
        s = np.asarray(self.shifts, dtype=float).reshape(-1, 3)
        if c.shape[0] != s.shape[0] or (c.size and (c.min() < 0 or c.max() >= n)):
            raise HCVInputError(f"{who}: contacts must be pairs of bodies 0..{n - 1}, one "
                                "shift each")  # fmt: skip
        object.__setattr__(self, "contacts", c)
        object.__setattr__(self, "shifts", s)
        gaps = np.abs(self._lengths(self.positions[None])[0] - 2.0 * self.radius)
        if gaps.size and float(gaps.max()) > _BOND_RTOL * 2.0 * self.radius:
            bad = int(np.argmax(gaps))
            raise HCVInputError(f"{who}: contact {bad} {tuple(c[bad].tolist())} is "
                                f"{gaps[bad]:.3g} m off touching at the start")  # fmt: skip
        if not (math.isfinite(self.dt) and self.dt > 0):
            raise HCVInputError(f"{who}: dt must be > 0 (s), got {self.dt!r}")
        steps = self.n_steps
        if (
            isinstance(steps, bool)
            or not isinstance(steps, int)
            or not 1 <= steps <= MAX_CODE_STEPS
        ):
            raise HCVInputError(f"{who}: n_steps must be an integer in [1, {MAX_CODE_STEPS}], "
                                f"got {steps!r}")  # fmt: skip

    @property
    def n_bodies(self) -> int:
        """Number of bodies N."""
        return len(self.masses)

    @property
    def planar(self) -> bool:
        """A 2-D layer: z not periodic, every centre at one height, no velocity along z."""
        z = self.positions[:, 2]
        return (
            (not self.periodic[2]) and bool(np.all(z == z[0])) and not np.any(self.velocities[:, 2])
        )

    def stop_kinetic(self, cap: float) -> float:
        """`stop_energy`, at most ``cap`` times the initial kinetic energy (J)."""
        m = np.asarray(self.masses, dtype=float)
        ke0 = 0.5 * float(np.sum(m[:, None] * self.velocities**2))
        return min(self.stop_energy, cap * ke0)

    def _lengths(self, x: np.ndarray) -> np.ndarray:
        """|x_j + s - x_i| of every contact (m) for positions x of shape (samples, N, 3)."""
        i, j = self.contacts[:, 0], self.contacts[:, 1]
        d = x[:, j, :] + self.shifts[None, :, :] - x[:, i, :]
        return np.sqrt(np.sum(d * d, axis=2))


@dataclass
class LatticeRun:
    """What a code returns for a `LatticeRequest`: the state after every step. SI units.

    Attributes
    ----------
    x, v : numpy.ndarray
        Positions (m, unwrapped: continuous from the start) and velocities (m/s), shape
        (samples, N, 3); sample 0 is the start. A run that blew up may hold inf/NaN or
        stop early (``meta`` says why).
    meta : dict
        Code, version, inputs written; ``v_staggering`` as for a chain (`ChainRun`).
    """

    x: np.ndarray
    v: np.ndarray
    meta: dict = field(default_factory=dict)


def _unwrap(x: np.ndarray, req: LatticeRequest) -> np.ndarray:
    """Positions continuous in time along the periodic axes (a wrap is a jump over half a box)."""
    box = np.array(req.box)
    per = np.array(req.periodic)
    with np.errstate(invalid="ignore"):
        d = np.diff(x, axis=0)
        jump = np.where(per, np.round(d / box), 0.0)
        jump = np.where(np.isfinite(jump), jump, 0.0)
    out = x.copy()
    out[1:] -= np.cumsum(jump, axis=0) * box
    return out


def lattice_run_from_mapping(out, req: LatticeRequest, who: str) -> LatticeRun:
    """Check what a code returned for ``req`` (a `LatticeRun` or a mapping with x, v, meta)
    and unwrap its positions.

    Raises
    ------
    AdapterOutputError
        One line: a missing key, a wrong shape, more samples than steps + 1.
    """
    x, v, meta = _checked_states(out, LatticeRun, "lattice", (req.n_bodies, 3), req.n_steps, who)
    return LatticeRun(_unwrap(x, req), v, meta)


def lattice_energy(req: LatticeRequest, run: LatticeRun) -> np.ndarray:
    """Kinetic plus elastic energy (J) of each sample, with the scene's own law U(q).

    q = 2 R - |x_j + s - x_i| of each listed contact along the actual line of centres,
    only q > 0 a contact (the codes' neighbour lists find no other pair: a pair not
    listed is more than 2 R apart until a run has blown up). A leapfrog code's kinetic
    energy is that of the half step (`chain_energy` says why that is harmless). NaN where
    a sample is not finite.
    """
    m = np.asarray(req.masses, dtype=float)
    ke = 0.5 * np.sum(m[None, :, None] * run.v * run.v, axis=(1, 2))
    with np.errstate(all="ignore"):
        q = 2.0 * req.radius - req._lengths(run.x)
        u = np.where(q > 0, req.potential._U(np.maximum(q, 0.0)), 0.0)
        e = ke + np.sum(u, axis=1)
    bad = ~(np.all(np.isfinite(run.x), axis=(1, 2)) & np.all(np.isfinite(run.v), axis=(1, 2)))
    return np.where(bad | ~np.isfinite(e), np.nan, e)
