"""Chain codes written for the tests of contract item 14 (`verification/test_assembly_codes.py`).

`verlet_chain` is an independent velocity Verlet of a `ChainRequest` (numpy, nothing of the
suite's kernels): the reference the real codes' positions are checked against.
`VerletChainCode` is a third-party adapter built on it (``hcv dt-crit SCENE --adapter
verification._chain_codes:VerletChainCode``); `CrashingChainCode` fails every run and
`MalformedChainCode` returns one body too few, so that ``hcv`` ends in one line.
"""

from __future__ import annotations

import numpy as np

from reference_impl.adapters.base import AdapterRunError, ChainRequest, ChainRun, ContactAdapter

__all__ = ["CrashingChainCode", "MalformedChainCode", "VerletChainCode", "verlet_chain"]


def verlet_chain(req: ChainRequest) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Velocity Verlet of the chain: positions, on-step and half-step velocities per step.

    The law is the request's U'(q) = k q^p on every overlap q > 0 (spheres: 2 R minus the
    distance of the centres; walls: R minus the distance to the plane).
    """
    m = np.asarray(req.masses, dtype=float)
    k, p, R = float(req.potential.k), float(req.potential.p), req.radius
    x, v = req.x0().copy(), np.asarray(req.velocities, dtype=float).copy()
    walls = req.wall_planes()

    def force(x):
        f = np.zeros_like(x)
        q = 2 * R - np.diff(x)
        fc = np.where(q > 0, k * np.maximum(q, 0.0) ** p, 0.0)
        f[:-1] -= fc
        f[1:] += fc
        for plane, side in walls:
            i = 0 if side < 0 else -1
            qw = R - side * (plane - x[i])
            f[i] -= side * (k * qw**p if qw > 0 else 0.0)
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
            if not np.all(np.isfinite(x)) or 0.5 * float(np.sum(m * v * v)) > req.stop_energy:
                break
    return np.array(xs), np.array(vs), np.array(hs)


class VerletChainCode(ContactAdapter):
    """A third-party code that runs chains (contract item 14) and gives one advice."""

    name = "verlet-chain"
    isolate = False
    supports_assembly = True

    def _impact_impl(self, scene):  # pragma: no cover - chains only
        raise AdapterRunError("verlet-chain runs chains only")

    def _assembly_impl(self, request):
        x, v, _ = verlet_chain(request)
        return ChainRun(x, v, {"code": "verlet-chain"})

    def step_advice(self, request) -> dict:
        # one advice the test can check the verdict of: a quarter of the smallest R / v0
        return {"quarter-crossing": 0.25 * request.radius / max(map(abs, request.velocities))}


class CrashingChainCode(VerletChainCode):
    """A chain code whose every run fails (a crash of the code, not bad input)."""

    name = "crashing-chain"

    def _assembly_impl(self, request):
        raise AdapterRunError("crashing-chain: segmentation fault (simulated)")


class MalformedChainCode(VerletChainCode):
    """A chain code that returns one body too few (malformed output)."""

    name = "malformed-chain"

    def _assembly_impl(self, request):
        x, v, _ = verlet_chain(request)
        return {"x": x[:, :-1], "v": v[:, :-1]}
