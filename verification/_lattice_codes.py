"""References for the codes' lattice runs (`verification/test_assembly_codes_lattice.py`).

`verlet_lattice` is an independent velocity Verlet of a `LatticeRequest` (numpy, nothing of
the suite's kernels): the forces along the actual line of centres of each listed pair, as
the codes compute them. `kernel_lattice` runs the suite's own assembly step
(`reference_impl.integrators.assembly_kernel._lanes`, one lane, one step per call) on the
scene's model and returns its positions, sites plus displacements: what the suite's
searches integrate. `VerletLatticeCode` is a third-party adapter built on `verlet_lattice`.
"""

from __future__ import annotations

import numpy as np

from reference_impl.adapters.base import AdapterDeclined, ContactAdapter, LatticeRequest, LatticeRun
from reference_impl.integrators.assembly_kernel import ST_PENDING, _lanes
from reference_impl.integrators.verlet_kernel import kernel_terms

__all__ = ["VerletLatticeCode", "kernel_lattice", "verlet_lattice"]


def verlet_lattice(req: LatticeRequest) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Velocity Verlet of the lattice: positions, on-step and half-step velocities per step.

    The law is the request's U'(q) = k q^p on every listed pair with q = 2 R - |x_j + s -
    x_i| > 0, along that line of centres (positions are never wrapped: the shifts hold).
    """
    m = np.asarray(req.masses, dtype=float)[:, None]
    k, p, R = float(req.potential.k), float(req.potential.p), req.radius
    i, j = req.contacts[:, 0], req.contacts[:, 1]
    x, v = req.positions.copy(), req.velocities.copy()

    def force(x):
        d = x[j] + req.shifts - x[i]
        r = np.sqrt(np.sum(d * d, axis=1))
        q = 2 * R - r
        fc = np.where(q > 0, k * np.maximum(q, 0.0) ** p, 0.0)[:, None] * d / r[:, None]
        f = np.zeros_like(x)
        np.add.at(f, i, -fc)  # repulsive: i pushed away from j
        np.add.at(f, j, fc)
        return f

    xs, vs, hs = [x.copy()], [v.copy()], [v.copy()]
    a = force(x) / m
    with np.errstate(all="ignore"):  # a runaway overflows: a result, not an error
        for _ in range(req.n_steps):
            half = v + 0.5 * req.dt * a
            x = x + req.dt * half
            a = force(x) / m
            v = half + 0.5 * req.dt * a
            xs.append(x.copy())
            vs.append(v.copy())
            hs.append(half.copy())
    return np.array(xs), np.array(vs), np.array(hs)


def kernel_lattice(model, req: LatticeRequest) -> np.ndarray:
    """The suite's assembly kernel on ``model`` at the request's step: positions (m) of
    every body after every step, shape (n_steps + 1, N, 3) (sites of ``req`` plus u)."""
    a = model.assembly
    fam, par = kernel_terms(model.potential)
    n, d = a.n_bodies, a.dim
    one = np.ones(1)
    us, vv = np.zeros((1, n, d)), np.zeros((1, n, d))
    ths, ws = np.zeros((1, n, 0)), np.zeros((1, n, 0))
    Fs, Ts = np.zeros((1, n, d)), np.zeros((1, n, 0))
    st = np.full(1, ST_PENDING, dtype=np.int64)
    steps = np.zeros(1, dtype=np.int64)
    e0, eend, emax, qmax = (np.zeros(1) for _ in range(4))
    tripped = np.zeros(1, dtype=np.bool_)
    kt = np.zeros(a.n_contacts)
    cd = np.zeros(a.n_contacts)
    out = [req.positions.copy()]
    for _ in range(req.n_steps):
        # one step per call (budget 1); a horizon far beyond the run keeps the lane going
        _lanes(fam, par, float(model.potential.q_sup), bool(model.bonded), a.mass, np.zeros(n),
               a.ci, a.cj, np.ascontiguousarray(a.normal), a.off, a.radius, kt, cd,
               req.dt * one, one, np.ascontiguousarray(a.u0, dtype=float),
               np.ascontiguousarray(model.v_init, dtype=float), np.zeros((n, 0)),
               1e300, 1e300, 10**12, 10**12, 1,
               us, vv, ths, ws, Fs, Ts, st, steps, e0, eend, emax, qmax, tripped)  # fmt: skip
        x = req.positions.copy()
        x[:, :d] += us[0]
        out.append(x)
    return np.array(out)


class VerletLatticeCode(ContactAdapter):
    """A third-party code that runs lattices (contract item 14) and gives no advice."""

    name = "verlet-lattice"
    isolate = False
    supports_assembly = True
    supports_lattice = True

    def _impact_impl(self, scene):  # pragma: no cover - lattices only
        raise AdapterDeclined("verlet-lattice runs lattices only")

    def _assembly_impl(self, request):
        if not isinstance(request, LatticeRequest):
            raise AdapterDeclined("verlet-lattice runs lattices only")
        x, v, _ = verlet_lattice(request)
        return LatticeRun(x, v, {"code": "verlet-lattice"})
