"""The model of an assembly scene: its contact network, law, damping and initial state.

`assembly_model` turns a chain or lattice scene (`reference_impl.scenes.AssemblyScene`,
read by duck typing: this layer sits below the scenes) into the `AssemblyModel` the
kernel runs. The bodies of a lattice move along `STRIKER_DIRECTION`, a direction with
irrational ratios of its components, so that no mode's polarisation at a moving body's
site is orthogonal to it by symmetry (a lattice direction would leave out the modes
polarised across it); with rotations each also spins at its speed / R about that axis.
The contacts follow their lines of centres unless the springs are bonded
(`AssemblyModel.follows`).
"""

from __future__ import annotations

import math

import numpy as np

from reference_impl.assembly.geometry import chain, lattice
from reference_impl.assembly.lanes import AssemblyModel
from reference_impl.assembly.linear import linear_k
from reference_impl.errors import HCVInputError

__all__ = ["STRIKER_DIRECTION", "assembly_model"]

# Unit-less directions (normalised where used), one per dimension of a lattice.
STRIKER_DIRECTION = {
    2: np.array([1.0, math.sqrt(2.0) - 1.0]),
    3: np.array([1.0, math.sqrt(2.0) - 1.0, math.sqrt(3.0) - 1.5]),
}


def assembly_model(scene) -> AssemblyModel:
    """The `AssemblyModel` of an assembly scene: its network, law, damping and initial state."""
    f = scene.assembly
    if scene.kind == "chain":
        asm = chain(f.masses, f.walls, scene.gap or 0.0)
        v = np.zeros((asm.n_bodies, 1))
        if f.body_velocities is None:
            v[0, 0] = scene.velocities[0]
        else:
            v[:, 0] = f.body_velocities
        w = np.zeros((asm.n_bodies, 0))
        kt = 0.0
    else:
        asm = lattice(
            f.lattice,
            f.cells,
            f.masses[0],
            f.radius,
            periodic=f.periodic,
            gap=scene.gap or 0.0,
            tangential_ratio=f.tangential_ratio,
            rotation=f.rotation,
        )
        d = STRIKER_DIRECTION[asm.dim]
        d = d / np.linalg.norm(d)
        speed = np.zeros(asm.n_bodies)
        if f.body_velocities is None:
            speed[0] = scene.velocities[0]
        else:
            speed[:] = f.body_velocities
        v = speed[:, None] * d[None, :]
        w = np.zeros((asm.n_bodies, asm.rot_dim))
        if asm.rot_dim == 1:
            w[:, 0] = speed / f.radius
        elif asm.rot_dim == 3:
            w = speed[:, None] / f.radius * d[None, :]
        k = linear_k(scene.potential)
        kt = f.tangential_ratio * k if f.tangential_ratio > 0 else 0.0
    if scene.damping_law not in ("none", "universal"):
        raise HCVInputError(
            f"scene {scene.name!r}: an assembly runs damping law 'none' or 'universal', "
            f"got {scene.damping_law!r}"
        )
    return AssemblyModel(
        assembly=asm,
        potential=scene.potential,
        bonded=f.bonded,
        zeta=float(scene.zeta or 0.0) if scene.damping_law == "universal" else 0.0,
        k_tangential=kt,
        v_init=v,
        w_init=w,
    )
