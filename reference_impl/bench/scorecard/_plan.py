"""What ``hcv bench`` runs: the scenes, checked before any work, and the cells (one per
adapter variant and scene, with the reason a variant declines the scene).

Importable from `reference_impl.bench.scorecard.runner` as well.
"""

from __future__ import annotations

from collections.abc import Sequence

from reference_impl.adapters.base import AdapterScene
from reference_impl.errors import HCVInputError
from reference_impl.scenes import Scene, load_scene
from reference_impl.theory.laws import is_harmonic

__all__ = [
    "DEFAULT_SCENES",
    "MAX_SCENES",
    "MAX_SPEEDS",
    "bench_scene_names",
    "plan_cells",
    "resolve_scenes",
    "scene_damped",
    "speed_dependent_law",
]

# Scenes run when none are given (all in the one catalogue, `hcv scenes`).
DEFAULT_SCENES = ("hertz", "hertz-damped", "hooke-damped", "hertz-walls")
# Upper bounds checked before any work: each speed costs a main run, a critical-step
# search (~20 runs) and each scene a speed table (~6 runs); 32 speeds x 64 scenes is
# already ~40,000 adapter runs.
MAX_SCENES = 64
MAX_SPEEDS = 32


def bench_scene_names() -> list[str]:
    """Names of the benchmark's default scenes (embedded scenes, listed by ``hcv scenes``)."""
    return list(DEFAULT_SCENES)


def resolve_scenes(scenes: Sequence[str | Scene] | None) -> list[Scene]:
    """Scenes from names (embedded scenes), TOML paths or Scene objects.

    Raises
    ------
    HCVInputError
        No scene, more than `MAX_SCENES` scenes or `MAX_SPEEDS` speeds in one,
        a kind the bench does not run, zeta >= 1, or repeated names.
    """
    items = list(DEFAULT_SCENES if scenes is None else scenes)
    if not items:
        raise HCVInputError("no scenes given")
    if len(items) > MAX_SCENES:
        raise HCVInputError(f"{len(items)} scenes given; hcv bench runs at most {MAX_SCENES}")
    out = []
    for s in items:
        sc = s if isinstance(s, Scene) else load_scene(s)
        if sc.kind not in ("impact", "two-walls"):
            raise HCVInputError(
                f"scene {sc.name!r}: hcv bench runs impact and two-walls scenes, not {sc.kind!r}"
            )
        if len(sc.velocities) > MAX_SPEEDS:
            raise HCVInputError(
                f"scene {sc.name!r} has {len(sc.velocities)} speeds; hcv bench "
                f"runs at most {MAX_SPEEDS} per scene"
            )
        if sc.damping_law == "universal" and (sc.zeta or 0.0) >= 1.0:
            raise HCVInputError(
                f"scene {sc.name!r}: hcv bench needs damping zeta < 1, got "
                f"{sc.zeta!r} (the restitution asked, exp(-pi zeta / sqrt(1 - "
                "zeta^2)), is defined for zeta < 1 only)"
            )
        out.append(sc)
    names = [s.name for s in out]
    dup = {n for n in names if names.count(n) > 1}
    if dup:
        raise HCVInputError(f"scene names must be unique, {', '.join(sorted(dup))} repeats")
    return out


def scene_damped(scene: Scene) -> bool:
    """The scene's damping law dissipates (any law with a non-zero strength)."""
    law = scene.law
    if law is None or scene.damping_law == "universal":
        return scene.damping_law == "universal" and bool(scene.zeta)
    return not law.is_zero()


def speed_dependent_law(scene: Scene) -> str:
    """The scene's law name when its restitution depends on the impact speed (every
    damped law but the universal one, Theorem 3), else ""."""
    if is_harmonic(scene.damping_law) or not scene_damped(scene):
        return ""
    return scene.damping_law


def plan_cells(variants, scenes: Sequence[Scene]) -> list[tuple]:
    """One cell per variant and scene, variants first: (index, variant, scene, reason).

    ``reason`` is the variant's ``supports`` answer for the scene at its first speed
    (None: the scene is run).
    """
    plan = []
    for i, var in enumerate(variants):
        for sc in scenes:
            probe = AdapterScene.from_scene(sc, sc.velocities[0], 1.0, 1)
            plan.append((i, var, sc, var.supports(probe)))
    return plan
