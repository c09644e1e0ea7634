"""Scaffolding the built-in code adapters share (LAMMPS, Kratos DEM, LIGGGHTS, YADE,
MuJoCo): their options' parsing and checks, the default sphere radius, and the
refusals every one of them makes before it maps a scene.

What each code integrates and how a scene maps onto it stays in its own module; what
it is asked (the restitution at an end) is `reference_impl.adapters._asked`.
"""

from __future__ import annotations

import math

from reference_impl.adapters._records import AdapterScene
from reference_impl.errors import HCVInputError
from reference_impl.potentials.power import PowerLaw

__all__ = [
    "RADIUS_OVER_QMAX",
    "bool_option",
    "default_radius",
    "positive_option",
    "refuse_scene",
    "split_option",
]

# Overlap at the scene's largest speed as a fraction of the sphere radius (1 %): the
# radius does not enter a sphere-wall law once k is mapped, only the geometry.
RADIUS_OVER_QMAX = 100.0


def split_option(code: str, what: str, value, allowed: tuple, every: bool = True) -> tuple:
    """The values of a variant axis: one of ``allowed``, several joined by "+", or
    (with ``every``) None / "all" for every one.

    Raises
    ------
    HCVInputError
        One line naming the adapter, the option and the value not in ``allowed``.
    """
    if every and value in (None, "all"):
        return allowed
    items = tuple(x.strip() for x in str(value).split("+"))
    for x in items:
        if x not in allowed:
            raise HCVInputError(f"adapter {code}: {what} {x!r} is not one of {', '.join(allowed)}")
    return items


def positive_option(code: str, name: str, value, allow_zero: bool = False) -> float | None:
    """A finite number > 0 (>= 0 with ``allow_zero``) as a float; None stays None.

    Raises
    ------
    HCVInputError
        One line naming the adapter, the option and the value (a bool is refused too).
    """
    if value is None:
        return None
    if (
        isinstance(value, bool)
        or not isinstance(value, (int, float))
        or not math.isfinite(value)
        or value < 0
        or (value == 0 and not allow_zero)
    ):
        raise HCVInputError(
            f"adapter {code}: {name} must be a number {'>=' if allow_zero else '>'} 0, "
            f"got {value!r}"
        )
    return float(value)


def bool_option(code: str, name: str, value) -> bool | None:
    """True or False (None stays None).

    Raises
    ------
    HCVInputError
        One line naming the adapter, the option and the value.
    """
    if value is not None and not isinstance(value, bool):
        raise HCVInputError(f"adapter {code}: {name} must be true or false, got {value!r}")
    return value


def default_radius(scene: AdapterScene, radius: float | None) -> float:
    """Sphere radius R (m): ``radius`` when given, else `RADIUS_OVER_QMAX` times the
    conservative turning point at the scene's largest speed."""
    if radius is not None:
        return float(radius)
    vmax = max(scene.velocities or (scene.v0,))
    q_top = float(scene.potential.turning_point(0.5 * scene.mass * vmax * vmax))
    return RADIUS_OVER_QMAX * q_top


def refuse_scene(
    adapter, scene: AdapterScene, *, configure: str, powers: tuple, no_power: str
) -> str | None:
    """The refusals every built-in code adapter makes first (one line each), or None.

    Parameters
    ----------
    adapter : ContactAdapter
        A code adapter with ``single`` (one variant configured) and ``label``.
    scene : AdapterScene
        The run asked.
    configure : str
        What one variant fixes, e.g. "damping model and geometry".
    powers : tuple of float
        The exponents p of U' = k q^p the variant integrates.
    no_power : str
        The refusal when the potential is not such a power law.
    """
    if not adapter.single:
        return f"configure one {configure} (see variants())"
    if scene.kind != "impact":
        return f"{adapter.label} runs single impacts only (scene kind {scene.kind!r})"
    law = scene.universal_only(adapter.label)
    if law:
        return law
    pot = scene.potential
    if type(pot) is not PowerLaw or pot.p not in powers:
        return no_power
    return None
