"""YADE on a chain of spheres (contract item 14) and its own step advice.

The chain of a `ChainRequest` as a YADE user builds it (the YADE side is ``_assembly``
and ``_assembly_advice`` of `reference_impl.adapters._yade_server`): spheres of one ``FrictMat``
on the x axis, ``utils.wall`` planes at the ends, Hertz-Mindlin without damping
(``Ip2_FrictMat_FrictMat_MindlinPhys`` + ``Law2_ScGeom_MindlinPhys_Mindlin``),
``NewtonIntegrator(damping=0)``, no gravity.

Hertz-Mindlin (see `reference_impl.adapters.yade`): U' = 4/3 E* sqrt(R*) q^(3/2) with
E* = Y/2 (nu = 0) and R* = R/2 between two spheres and on a wall alike (YADE counts a
wall as a sphere of the same radius), so one material with Y = 2 (3/4) k / sqrt(R/2)
gives the scene's k on every contact. The density is m / (4/3 pi R^3) so that
``PWaveTimeStep`` reads the scene's bodies; each mass is then set to m_i exactly.

YADE is leapfrog: after a step the position is x[n + 1] and the velocity v[n + 1/2]
(``v_staggering`` 0.5 in the run's meta; `reference_impl.adapters._assembly_request.chain_energy`
says what that does to the energy).

Step advice, as YADE computes it: ``utils.PWaveTimeStep()`` (R / sqrt(Y / rho), the
smallest over the bodies), and ``GlobalStiffnessTimeStepper`` (active, updating every
step, its default safety coefficient 0.8): it sets ``O.dt`` itself from the contacts'
current stiffness, and its advice is the smallest step it set along a run of the chain
that it drove.
"""

from __future__ import annotations

import math

import numpy as np

from reference_impl.adapters._assembly_request import ChainRequest, ChainRun
from reference_impl.adapters._records import AdapterDeclined, AdapterRunError

__all__ = ["chain_scene", "hertz_material", "parse_advice", "parse_chain"]


def hertz_material(req, what: str) -> dict:
    """The server's material of an assembly: R (m), Y (Pa), density (kg/m^3), masses (kg).

    Parameters
    ----------
    req : ChainRequest or LatticeRequest
        The assembly.
    what : str
        ``"chains"`` or ``"lattices"``, for the declines.

    Raises
    ------
    AdapterDeclined
        The law is not Hertz (Hertz-Mindlin is U' = k q^(3/2)), or the bodies' masses
        differ (one material).
    """
    pot = req.potential
    if type(pot).__name__ != "PowerLaw" or getattr(pot, "p", None) != 1.5:
        raise AdapterDeclined(f"yade runs Hertz {what} only (power law, p = 1.5), got {pot!r}")
    R = float(req.radius)
    masses = [float(m) for m in req.masses]
    if len(set(masses)) > 1:
        # one material, one density: PWaveTimeStep would read one body's density for all
        raise AdapterDeclined(f"yade {what} take one mass for every body (one material)")
    return {
        "R": R,
        "young": float(2.0 * 0.75 * float(pot.k) / math.sqrt(0.5 * R)),
        "density": masses[0] / (4.0 / 3.0 * math.pi * R**3),
        "masses": masses,
    }


def chain_scene(req: ChainRequest) -> dict:
    """The server's description of a chain: material, bodies, walls (SI units).

    Raises
    ------
    AdapterDeclined
        The law is not Hertz (Hertz-Mindlin is U' = k q^(3/2)), or the masses differ.
    """
    return {
        **hertz_material(req, "chains"),
        "x0": [float(x) for x in req.x0()],
        "velocities": [float(v) for v in req.velocities],
        "walls": [[float(x), int(side)] for x, side in req.wall_planes()],
    }


def parse_chain(ans: dict, req: ChainRequest, meta: dict) -> ChainRun:
    """The server's answer to a ``chain`` request as a `ChainRun` (null -> NaN)."""
    try:
        x = np.array([[np.nan if a is None else a for a in row] for row in ans["x"]], float)
        v = np.array([[np.nan if a is None else a for a in row] for row in ans["v"]], float)
    except (KeyError, TypeError, ValueError):
        raise AdapterRunError("yade answered a malformed chain run") from None
    return ChainRun(x, v, {**meta, "v_staggering": 0.5})


def parse_advice(ans: dict) -> dict:
    """{"PWaveTimeStep": s, "GlobalStiffnessTimeStepper": s} from the server's answer."""
    out = {"PWaveTimeStep": float(ans["pwave"])}
    # None: no contact was stiff at any step of the run (the stepper kept its default)
    gst = ans.get("gst")
    out["GlobalStiffnessTimeStepper"] = math.inf if gst is None else float(gst)
    return out
