"""What a command or a sweep case runs: one place from a loaded scene to its results.

``hcv solve`` and the sweep's ``solve`` task both call `solve_scene`; ``hcv dt-crit`` and
the sweep's ``dt-crit`` task both call `search_loaded_scene`, so a scene gives the same
result whichever way it is run.
"""

from __future__ import annotations

import math

from reference_impl.errors import HCVInputError
from reference_impl.exact._rtol import checked_rtol
from reference_impl.exact.api import solve
from reference_impl.stability.bound import dt_safe
from reference_impl.stability.result import DtCritResult
from reference_impl.theory.action import action, period

__all__ = ["restitution_spread", "search_assembly_scene", "search_loaded_scene", "solve_scene"]

# Scene kinds that are assemblies (`reference_impl.scenes._assembly`): no single impact to
# solve; ``hcv dt-crit`` runs `search_assembly_scene` on them.
_ASSEMBLY_KINDS = ("chain", "lattice")


def solve_scene(scene, rtol: float | None = None) -> list[dict]:
    """Solve every velocity of an impact scene; one dict per velocity.

    Fields (SI units): v0, damping_law, zeta (universal law only, else None),
    max_penetration, max_force (elastic force U'(q_max)), peak_force (peak total
    contact force max (U' + C q')), dt_safe (supremum over [0, q_max]),
    dt_safe_shortcut (2 m v0 / U'(q_max)), geometry, contact_time and restitution
    (end at q = 0, the "overlap" end, the theory's definition; a body that never
    returns to q = 0, e.g. zeta >= 1 with a leading exponent >= 2 or a constant
    dashpot at low speed, has contact_time None and returns_to_q0 False, an answer,
    not a failure), contact_time_zero_force and restitution_zero_force (the
    "zero-force" end, where U' + C q' first vanishes after q_max, as in codes that
    forbid tension), action J(E) and period T(E) with the paper's definitions
    (section 4) at E = m v0^2 / 2, and the error bound of the contact time
    (quadrature_error, s). Each law is solved where its registry entry says
    (`reference_impl.exact.api.solve`): the universal law and ``none`` by the exact
    quadrature, the others by `reference_impl.exact.general_law` (or the generic route).
    ``rtol`` is the solver's accuracy argument (None: full accuracy; see
    `reference_impl.exact.api.solve`).
    """

    if scene.kind in _ASSEMBLY_KINDS:
        raise HCVInputError(
            f"scene {scene.name!r} is a {scene.kind} (an assembly): it has no single impact to "
            "solve; run hcv dt-crit on it"
        )
    rtol = checked_rtol(rtol, "hcv solve --rtol")  # refused before any impact is solved
    law = scene.law
    # the universal law's zeta when the harmonic map solves the law, else None
    zeta = law.harmonic_zeta
    rows = []
    for v0 in scene.velocities:
        # the one entry point chooses the strategy from the law's registry entry
        sol = solve(scene.potential, scene.mass, v0, law=law, rtol=rtol)
        err_t = sol.quadrature_error if zeta is not None else sol.error_time
        safe = dt_safe(scene.potential, scene.mass, v0)
        E = 0.5 * scene.mass * v0 * v0
        rows.append(
            {
                "v0": v0,
                "damping_law": law.name,
                "zeta": zeta,
                "max_penetration": sol.max_penetration,
                "max_force": sol.max_force,
                "peak_force": sol.peak_force,
                "dt_safe": safe.dt_safe,
                "dt_safe_shortcut": safe.dt_shortcut,
                "dt_safe_at_q": safe.q_star,
                "geometry": safe.geometry,
                # inf is the answer for a contact that creeps back forever; it is written
                # as an absence (null), not as a number.
                "contact_time": sol.contact_time if math.isfinite(sol.contact_time) else None,
                "returns_to_q0": math.isfinite(sol.contact_time),
                "restitution": sol.restitution,
                "contact_time_zero_force": sol.contact_time_zero_force,
                "restitution_zero_force": sol.restitution_zero_force,
                "action": action(scene.potential, scene.mass, E),
                "period": period(scene.potential, scene.mass, E),
                "quadrature_error": err_t,
            }
        )
    return rows


def restitution_spread(rows: list[dict]) -> dict | None:
    """max - min of the restitution at each end over the speeds (None for one speed)."""
    if len(rows) < 2:
        return None
    out = {}
    for end, key in (("overlap", "restitution"), ("zero-force", "restitution_zero_force")):
        vals = [r[key] for r in rows]
        out[end] = max(vals) - min(vals)
    return out


def search_loaded_scene(scene, criterion: str | None = None, progress=None) -> list[DtCritResult]:
    """`search_scene` on a loaded scene: its gap, its universal damping, a criterion text.

    The one place where a scene file becomes a search, shared by ``hcv dt-crit`` and
    the sweep's ``dt-crit`` task, so both give the same result for the same scene.

    Parameters
    ----------
    scene : reference_impl.scenes.Scene
        A validated scene.
    criterion : str, optional
        ``--criterion`` text (`parse_criterion`; an empty text is refused); None for the
        scene kind's default criterion.
    progress : callable, optional
        As for `search_scene`.
    """
    from reference_impl.stability.search import default_criterion, parse_criterion, search_scene

    if scene.kind in _ASSEMBLY_KINDS:
        raise HCVInputError(
            f"scene {scene.name!r} is a {scene.kind} (an assembly): its search is "
            "search_assembly_scene"
        )
    if scene.law.harmonic_zeta is None:
        # The Verlet lanes integrate the universal law only; running the scene undamped
        # would answer another question.
        raise HCVInputError(
            f"scene {scene.name!r}: hcv dt-crit runs damping law 'none' or 'universal', "
            f"got {scene.damping_law!r}"
        )
    crit = (
        parse_criterion(criterion, scene.kind)
        if criterion is not None
        else default_criterion(scene.kind)
    )
    return search_scene(
        scene.potential,
        scene.mass,
        scene.velocities,
        scene.kind,
        gap=scene.gap,
        zeta=scene.zeta if scene.damping_law == "universal" else None,
        criterion=crit,
        progress=progress,
    )


def search_assembly_scene(
    scene, horizons=None, n_lanes: int = 32, criterion: str | None = None, progress=None
) -> dict:
    """The critical step of an assembly scene as a distribution (``hcv dt-crit`` on a chain
    or lattice): `reference_impl.assembly.search.assembly_report` of its model.

    Parameters
    ----------
    scene : reference_impl.scenes.AssemblyScene
        A chain or lattice scene.
    horizons : sequence of int, optional
        Steps of each ensemble (default `reference_impl.assembly.search.HORIZONS`).
    n_lanes : int
        Lanes of each ensemble (their initial velocities differ in the last bits).
    criterion : str, optional
        ``factor=...,confirm_factor=...,confirm_horizon=...`` (`parse_criterion` of a
        sustained scene); its ``n_steps`` is refused: the horizons set it.
    progress : callable, optional
        ``progress(completed, total)``.
    """
    from reference_impl.assembly.model import assembly_model
    from reference_impl.assembly.search import HORIZONS, assembly_report
    from reference_impl.stability.search import parse_criterion

    kw = {}
    if criterion is not None:
        if "n_steps" in criterion:
            raise HCVInputError(
                f"criterion {criterion!r}: an assembly's horizons are set by --horizons, "
                "not n_steps"
            )
        c = parse_criterion(criterion, "two-walls")
        kw = dict(
            factor=c.factor, confirm_factor=c.confirm_factor, confirm_horizon=c.confirm_horizon
        )
    model = assembly_model(scene)
    return assembly_report(
        model,
        horizons=HORIZONS if horizons is None else horizons,
        n_lanes=n_lanes,
        progress=progress,
        **kw,
    )
