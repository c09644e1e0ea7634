"""What the tests of the codes on assemblies share (issue 39 section 4, contract item 14).

`verification/test_assembly_codes.py` (chains) and `verification/test_assembly_codes_lattice.py`
(periodic lattices) use:

- references: `verlet_chain` and `verlet_lattice`, independent velocity Verlets of a request
  (numpy, nothing of the suite's kernels; a lattice's forces along the actual line of centres
  of each listed pair, as the codes compute them), one loop `_verlet` (the suite's own
  kernel on the same request is `reference_impl.assembly.lanes.displacements`);
- third-party codes for ``hcv dt-crit SCENE --adapter verification._assembly_codes:NAME``:
  `VerletChainCode` (one advice) and `VerletLatticeCode` (none) built on the references,
  `CrashingChainCode` (every run fails), `MalformedChainCode` (one body too few),
  `QuittingChainCode` (every run stops half-way, below the stop energy),
  `AbortingChainCode` and `SegfaultingChainCode` (isolated; every run kills their process),
  `SleepingChainCode` (isolated; every run sleeps an hour: ``--timeout``);
- checks of a real code: `code_fixture` (its adapter, one per test module), `needs` (its
  mark, and its skip where it is not installed), `dt_safe`,
  `assert_run_is_verlet` (positions and velocities against a reference),
  `assert_dt_crit_in_suite_ensemble` and `assert_advice_is_the_codes`.
"""

from __future__ import annotations

import ctypes
import math
import os
import time
from pathlib import Path

import numpy as np
import pytest

from reference_impl.adapters.base import (
    AdapterDeclined,
    AdapterRunError,
    ChainRequest,
    ChainRun,
    ContactAdapter,
    LatticeRequest,
    LatticeRun,
)
from reference_impl.adapters.lammps import LammpsAdapter, lammps_available
from reference_impl.adapters.liggghts import LiggghtsAdapter, liggghts_available
from reference_impl.adapters.yade import YadeAdapter, yade_available
from reference_impl.assembly.lanes import initial_energy
from reference_impl.assembly.model import assembly_model
from reference_impl.assembly.safe import dt_safe_conventions
from reference_impl.assembly.search import search_ensemble
from reference_impl.bench.assembly_codes import CODE_GRID, code_dt_crit
from reference_impl.stability.criteria import EnergyGrowth
from verification.assertions import assert_close, assert_true

__all__ = [
    "CLAIM",
    "K",
    "M",
    "R",
    "AbortingChainCode",
    "CrashingChainCode",
    "MalformedChainCode",
    "QuittingChainCode",
    "SegfaultingChainCode",
    "VerletChainCode",
    "VerletLatticeCode",
    "assert_advice_is_the_codes",
    "assert_dt_crit_in_suite_ensemble",
    "assert_run_is_verlet",
    "code_fixture",
    "dt_safe",
    "needs",
    "verlet_chain",
    "verlet_lattice",
]

CLAIM = "assembly-codes"  # the codes on assemblies (issue 39 section 4), not a paper claim
K, M, R = 1.0879e10, 4.1103e-3, 5e-3  # chain-hertz and the lattice-hertz scenes: N/m^1.5, kg, m
# Each real code: its adapter as the tests open it (YADE given the restitution input "en"),
# and the check that it is installed (None, or the one-line reason with the install line).
_CODES = {
    "liggghts": (lambda: LiggghtsAdapter(model="hertz"), liggghts_available),
    "lammps": (LammpsAdapter, lammps_available),
    "yade": (lambda: YadeAdapter(input="en"), yade_available),
}


# -- references ---------------------------------------------------------------------------


def _verlet(req, x: np.ndarray, v: np.ndarray, force, m: np.ndarray):
    """Velocity Verlet of ``force`` from (x, v) at the request's step: positions (m), on-step
    and half-step velocities (m/s) per step, up to ``n_steps`` steps; it stops after the
    first non-finite position or kinetic energy above the request's stop energy (J), as
    the contract lets a code. ``m`` (kg) broadcasts against x."""
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


def verlet_chain(req: ChainRequest) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Velocity Verlet of the chain: positions, on-step and half-step velocities per step.

    The law is the request's U'(q) = k q^p on every overlap q > 0 (spheres: 2 R minus the
    distance of the centres; walls: R minus the distance to the plane).
    """
    m = np.asarray(req.masses, dtype=float)
    k, p, R = float(req.potential.k), float(req.potential.p), req.radius
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

    v0 = np.asarray(req.velocities, dtype=float).copy()
    return _verlet(req, req.x0().copy(), v0, force, m)


def verlet_lattice(req: LatticeRequest) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Velocity Verlet of the lattice: positions, on-step and half-step velocities per step.

    The law is the request's U'(q) = k q^p on every listed pair with q = 2 R - |x_j + s -
    x_i| > 0, along that line of centres (positions are never wrapped: the shifts hold).
    """
    m = np.asarray(req.masses, dtype=float)[:, None]
    k, p, R = float(req.potential.k), float(req.potential.p), req.radius
    i, j = req.contacts[:, 0], req.contacts[:, 1]

    def force(x):
        d = x[j] + req.shifts - x[i]
        r = np.sqrt(np.sum(d * d, axis=1))
        q = 2 * R - r
        fc = np.where(q > 0, k * np.maximum(q, 0.0) ** p, 0.0)[:, None] * d / r[:, None]
        f = np.zeros_like(x)
        np.add.at(f, i, -fc)  # repulsive: i pushed away from j
        np.add.at(f, j, fc)
        return f

    return _verlet(req, req.positions.copy(), req.velocities.copy(), force, m)


# -- codes for hcv dt-crit --adapter -------------------------------------------------------


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


class QuittingChainCode(VerletChainCode):
    """A chain code whose every run stops half-way without running away (a code that
    quietly gives up): judged on the steps it ran, every step would read as stable."""

    name = "quitting-chain"

    def _assembly_impl(self, request):
        x, v, _ = verlet_chain(request)
        half = max(2, (request.n_steps + 1) // 2)
        return {"x": x[:half], "v": v[:half]}


class AbortingChainCode(VerletChainCode):
    """A chain code in a worker process (``isolate``) whose run aborts it (SIGABRT), as a C
    library's failed assertion does."""

    name = "aborting-chain"
    isolate = True

    def _assembly_impl(self, request):
        os.abort()


class SegfaultingChainCode(VerletChainCode):
    """A chain code in a worker process whose run reads address 0 (SIGSEGV), as a code's
    C library does with a bad pointer."""

    name = "segfaulting-chain"
    isolate = True

    def _assembly_impl(self, request):
        ctypes.string_at(0)


class SleepingChainCode(VerletChainCode):
    """A chain code in a worker process whose run never ends (a code stuck in a loop): it
    writes its process id to ``sleeping-chain.pid`` in the working directory, then sleeps,
    so that a test can see the worker killed at ``hcv dt-crit --timeout``."""

    name = "sleeping-chain"
    isolate = True

    def _assembly_impl(self, request):
        Path("sleeping-chain.pid").write_text(str(os.getpid()))
        time.sleep(3600)


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


# -- checks of a real code ----------------------------------------------------------------


def code_fixture(name: str):
    """A module-scoped fixture named ``name`` of that code's adapter, closed after the module
    (``liggghts = code_fixture("liggghts")`` in a test module)."""

    @pytest.fixture(scope="module", name=name)
    def _adapter():
        a = _CODES[name][0]()
        yield a
        a.close()

    return _adapter


def needs(name: str):
    """A test's decorator: the code's pytest mark (``-m liggghts`` selects its tests) and its
    skip, with the one-line reason and install line, where the code is not installed."""
    missing = _CODES[name][1]()

    def apply(test):
        test = pytest.mark.skipif(missing is not None, reason=str(missing))(test)
        return getattr(pytest.mark, name)(test)

    return apply


def dt_safe(sc) -> float:
    """Delta t_safe (s) of a scene under the paper's convention, at its initial energy."""
    model = assembly_model(sc)
    return dt_safe_conventions(model, initial_energy(model))["paper"]


def assert_run_is_verlet(adapter, req, reference, *, half_step_v: bool, x_tol: float,
                         v_tol: float, what: str):  # fmt: skip
    """The code's run of ``req``: positions within ``x_tol`` (m) of the reference's
    (`verlet_chain`, `verlet_lattice`), velocities within ``v_tol`` (m/s) of its on-step
    ones, or of its half-step ones for a leapfrog code (``half_step_v``). Returns the run."""
    run = adapter.assembly(req)
    x, v, h = reference(req)
    err = float(np.max(np.abs(run.x - x)))
    assert_true(err <= x_tol, got=f"max |x - x_verlet| = {err:.3g} m", should=f"<= {x_tol:g} m",
                claim=CLAIM, call=f"{adapter.label} {what}")  # fmt: skip
    want = h if half_step_v else v  # leapfrog: the velocity of the half step
    assert_close(run.v[1:], want[1:], rtol=0, atol=v_tol, claim=CLAIM,
                 call=f"{adapter.label} {what} velocities")  # fmt: skip
    return run


def assert_dt_crit_in_suite_ensemble(adapter, sc, horizon: int) -> None:
    """The code's Delta t_crit of ``sc`` (the suite's search on the code's runs) lies within
    the suite's own 16-lane ensemble of the same scene, horizon (steps), rule and grid."""
    safe = dt_safe(sc)
    crit = EnergyGrowth(n_steps=horizon)
    found = code_dt_crit(adapter, sc, safe, criterion=crit)
    ens = search_ensemble(assembly_model(sc), safe, n_lanes=16, criterion=crit, grid=CODE_GRID)
    # Contacts open and close: the run is chaotic, round-off of the code (or of the last
    # bits of the start, or the kernel's fixed normals on a lattice) moves the smallest
    # failing step within the ensemble's spread (0.50-0.52 Delta t_safe for the chain of
    # N = 2); two grid resolutions (0.02 Delta t_safe) more on either side for the
    # k-section's bracket of each.
    slack = 2 * CODE_GRID.resolution * safe
    lo, hi = float(ens.dt_crit.min()) - slack, float(ens.dt_crit.max()) + slack
    assert_true(lo <= found.dt_crit <= hi and found.evidence in ("confirmed", "domain"),
                got=f"dt_crit {found.dt_crit:.6g} s ({found.evidence})",
                should=f"in [{lo:.6g}, {hi:.6g}] s, the suite's ensemble", claim=CLAIM,
                call=f"code_dt_crit {adapter.label} {sc.name}")  # fmt: skip


def assert_advice_is_the_codes(adapter, request_at, safe: float, names, material: str,
                               what: str) -> None:  # fmt: skip
    """The advice is a property of the assembly, not of the step it is asked at: the code
    gives every one of ``names``, each a finite step (s), and the one that reads only the
    material (``material``: LIGGGHTS' Rayleigh time, YADE's PWaveTimeStep) is the same
    asked at 1e-3 and 2e-3 ``safe`` (``request_at(dt)`` builds the request)."""
    a1 = adapter.step_advice(request_at(1e-3 * safe))
    a2 = adapter.step_advice(request_at(2e-3 * safe))
    assert_true(set(a1) == set(names) and all(0 < t < math.inf for t in a1.values()),
                got=repr(a1), should=f"finite steps > 0 s named {sorted(names)}", claim=CLAIM,
                call=f"{adapter.label}.step_advice {what}")  # fmt: skip
    # 1e-6: the fractions are printed to 15 digits; LIGGGHTS' Hertz time reads the speeds
    # after its one step, which differ by ~dt k q / m (1e-3 of the start's) between the two
    # steps, and YADE's stepper the contacts of its run: only the material's time compares
    assert_close(a2[material], a1[material], rtol=1e-6, claim=CLAIM,
                 call=f"{adapter.label}.step_advice {what} {material} at two steps")  # fmt: skip
