"""YADE on a periodic lattice of spheres (contract item 14) and its own step advice.

The lattice of a `LatticeRequest` as a YADE user builds it (the YADE side is ``_assembly``
and ``_assembly_advice`` of `reference_impl.adapters._yade_server`): ``O.periodic = True``
with the request's box as ``O.cell``, spheres of one ``FrictMat`` (friction angle 0, so
Mindlin's tangential force is zero: normal Hertz only), Hertz-Mindlin without damping,
``NewtonIntegrator(damping=0)``, no gravity. YADE's cell is periodic along all three axes:
a 2-D layer's box is 4 R high, so that a sphere's images along z stand 4 R apart and never
touch it (the same contacts as the request's non-periodic z), and no force has a z part.
Material, density and masses as for a chain (`reference_impl.adapters._yade_chain`).

YADE is leapfrog: after a step the position is x[n + 1] and the velocity v[n + 1/2]
(``v_staggering`` 0.5); the lattice starts touching (no force), so its positions are those
of velocity Verlet. The advice is ``PWaveTimeStep()`` and ``GlobalStiffnessTimeStepper``,
as for a chain.
"""

from __future__ import annotations

import numpy as np

from reference_impl.adapters._lattice_request import LatticeRequest, LatticeRun
from reference_impl.adapters._records import AdapterRunError
from reference_impl.adapters._yade_chain import hertz_material

__all__ = ["lattice_scene", "parse_lattice"]


def lattice_scene(req: LatticeRequest) -> dict:
    """The server's description of a lattice: material, cell, bodies (SI units).

    Raises
    ------
    AdapterDeclined
        The law is not Hertz, or the bodies' masses differ (one material).
    """
    return {
        **hertz_material(req, "lattices"),
        "cell": [float(b) for b in req.box],
        "x0": req.positions.tolist(),
        "velocities": req.velocities.tolist(),
    }


def parse_lattice(ans: dict, req: LatticeRequest, meta: dict) -> LatticeRun:
    """The server's answer to a ``lattice`` request as a `LatticeRun` (null -> NaN)."""
    try:
        x, v = (np.array([[[np.nan if a is None else a for a in body] for body in row]
                          for row in ans[key]], dtype=float) for key in ("x", "v"))  # fmt: skip
    except (KeyError, TypeError, ValueError):
        raise AdapterRunError("yade answered a malformed lattice run") from None
    return LatticeRun(x, v, {**meta, "v_staggering": 0.5})
