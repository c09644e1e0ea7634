"""What ``hcv calibrate`` reads from a scene's damping law: any registered law (issue 40 §3).

A calibration's references (the contact time that sets dt, the scene as asked) are the
exact solution of the scene's own law (`reference_impl.exact.solve.solve_impact` with
``law=``: the harmonic map for the universal law, the general-law solver or the generic
one for every other law). Besides a code's own option, the option searched may be the
scene law's strength (`LawFamily.strength`: ``zeta``, ``c``, ``A``, ``alpha``, a
polynomial's scale): the code is then sent the scene with its law at each strength tried,
which is how a code that takes its law from the scene (the reference adapter) is
calibrated, e.g. the Hunt-Crossley ``alpha`` delivering e at v.
"""

from __future__ import annotations

import dataclasses
import inspect
import math

from reference_impl.adapters.registry import parse_spec, resolve_class
from reference_impl.bench.calibration._options import check_option
from reference_impl.errors import HCVInputError
from reference_impl.exact.solve import solve_impact
from reference_impl.scenes import Scene, load_scene
from reference_impl.scenes._law_restitution import law_for_restitution
from reference_impl.theory.laws import law_family

__all__ = ["contact_time", "impact_scene", "option_class", "scene_at_strength",
           "searches_strength", "strength_range"]  # fmt: skip

# Default range of a strength search: this factor either side of the strength at which the
# exact law delivers the target (the code's error at the bench's resolutions moves e by a
# few per cent, i.e. the strength by far less than x4).
_SPAN = 4.0
# A harmonic-map law's zeta stays below critical damping (zeta >= 1 never returns to q = 0).
_ZETA_CAP = 0.99


def impact_scene(scene) -> Scene:
    """The scene (name, path or `Scene`), refused in one line when it is not an impact."""
    sc = scene if isinstance(scene, Scene) else load_scene(scene)
    if sc.kind != "impact":
        raise HCVInputError(f"scene {sc.name!r}: calibrate runs impact scenes, not {sc.kind!r}")
    return sc


def exact(sc: Scene, v0: float):
    """The exact solution of the scene's own law at ``v0`` (m/s)."""
    return solve_impact(sc.potential, sc.mass, v0, law=sc.law)


def contact_time(sc: Scene, v0: float) -> float:
    """Exact contact time (s) of the scene's law at ``v0``; one line when it has none."""
    t_c = float(exact(sc, v0).contact_time)
    if not (math.isfinite(t_c) and t_c > 0):
        raise HCVInputError(
            f"scene {sc.name!r}: its law {sc.law.name!r} has no finite contact time at "
            f"v0 = {v0:g} m/s (got {t_c!r}), so no dt = t_c / N"
        )
    return t_c


def searches_strength(adapter: str, param: str, sc: Scene) -> bool:
    """True when ``param`` is the strength of the scene's law and no option of the adapter:
    the search then varies the law sent to the code, not the code's input."""
    if param != law_family(sc.law.name).strength:
        return False
    target, _ = parse_spec(adapter)
    try:
        params = inspect.signature(resolve_class(target)).parameters
    except (TypeError, ValueError):
        return True
    return param not in params


def option_class(adapter: str, param: str, sc: Scene) -> type:
    """The adapter class when ``param`` is one of its options; else one line naming the
    option and the scene law's strength it could have been (`check_option`)."""
    try:
        return check_option(adapter, param)
    except HCVInputError as exc:
        msg = str(exc) + ("none" if str(exc).endswith("its options: ") else "")
        key = law_family(sc.law.name).strength
        also = f"; nor is it the scene law's strength {key!r}" if key else ""
        raise HCVInputError(f"{msg}{also} (scene {sc.name!r}, law {sc.law.name!r})") from None


def scene_at_strength(sc: Scene, s: float) -> Scene:
    """The scene with its law at strength ``s`` (its unit, `LawFamily.strength_unit`)."""
    law = sc.law.with_strength(s)
    zeta = float(s) if sc.damping_law == "universal" else sc.zeta
    return dataclasses.replace(sc, law=law, zeta=zeta, calibration=None)


def strength_range(sc: Scene, target: float, v0: float, end: str) -> tuple[float, float]:
    """Default range of a strength search: `_SPAN` either side of the strength at which
    the scene's exact law delivers ``target`` at ``v0`` (the one solve-to-restitution,
    `reference_impl.scenes._law_restitution.law_for_restitution`)."""
    _law, s = law_for_restitution(sc.potential, sc.mass, sc.law, target, v0, end)
    if not (math.isfinite(s) and s > 0):
        raise HCVInputError(
            f"scene {sc.name!r}: the law's strength for e = {target:g} is {s!r}; give --range LO HI"
        )
    hi = s * _SPAN
    if law_family(sc.law.name).route == "harmonic map":
        hi = min(hi, _ZETA_CAP)
    return s / _SPAN, hi
