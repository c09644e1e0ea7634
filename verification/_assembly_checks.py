"""What the assembly tests share: a linear search through a scene, and its settings.

Why 1e-6 relative is reachable for bonded linear springs: each normal mode of M x'' = -K x
is a scalar Verlet oscillator, bounded exactly for omega Delta t < 2 (trace of its
amplification matrix 2 - (omega Delta t)^2, determinant 1), so the boundary is sharp at
2 / omega_max with no integrator error; just above it the top mode grows by a factor
1 + sqrt(8 eps) a step (Delta t = (1 + eps) 2 / omega_max), so within `LINEAR_CRITERION`'s
5000 steps it crosses 100 E_0 from a mode share of 1e-4 once eps > ~2e-7 (every body
is given its own speed, `body_speeds`, so that every mode has a share); the bracket is
bisected to `LINEAR_GRID`'s 1e-9 of the reference step; and the confirmation level 1e6
E_0 counts a bounded orbit below the boundary (peak at most E_0 / (1 - (omega Delta t /
2)^2)) as a runaway only within 5e-7 of it. Each is below 1e-6.
"""

from __future__ import annotations

import math

from reference_impl.assembly.model import assembly_model
from reference_impl.assembly.search import search_ensemble
from reference_impl.scenes import parse_scene
from reference_impl.stability.criteria import EnergyGrowth, SearchGrid

__all__ = [
    "K", "LINEAR_CRITERION", "LINEAR_GRID", "LINEAR_RTOL", "M", "body_speeds", "linear_search",
    "scene_text",
]  # fmt: skip

# See the module docstring: horizon, confirmation and bracket of the linear checks.
LINEAR_CRITERION = EnergyGrowth(factor=100.0, n_steps=5000, confirm_factor=1e4, confirm_horizon=2)
# Coarse scan (the linear step lies between 0.2 and 1 reference step), fine bisection.
LINEAR_GRID = SearchGrid(lo=0.1, hi=1.1, step=0.1, resolution=1e-9, refine_points=4)
# The tolerance; the reasons it is reachable are in the module docstring.
LINEAR_RTOL = 1e-6

K = 1.0e6  # N/m, the springs of every linear check
M = 0.01  # kg


def body_speeds(n: int) -> list[float]:
    """n distinct speeds (m/s), 0.05 to 0.15, none a rational multiple of another's pattern."""
    return [0.1 + 0.05 * math.sin(1.0 + 2.399963 * i) for i in range(n)]


def scene_text(kind_lines: str, velocities="0.1") -> str:
    """A bonded linear assembly scene: ``kind_lines`` (kind, shape) plus the spring."""
    return (
        f'name = "linear"\n{kind_lines}\nmass = {M}\nvelocities = {velocities}\n'
        f'bonded = true\n[potential]\nfamily = "power"\nk = {K}\np = 1.0\n'
    )


def linear_search(kind_lines: str) -> tuple[float, object]:
    """(Delta t_crit measured by the suite's search on the scene, every body moving (s), its
    model)."""
    n = parse_scene(scene_text(kind_lines), "<linear>").assembly.n_bodies
    text = scene_text(kind_lines, repr(body_speeds(n)))
    model = assembly_model(parse_scene(text, "<linear>"))
    ref = 2.0 * math.sqrt(M / K)  # the single contact's 2 / omega
    ens = search_ensemble(model, ref, n_lanes=1, criterion=LINEAR_CRITERION, grid=LINEAR_GRID)
    return float(ens.dt_crit[0]), model
