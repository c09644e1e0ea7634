"""Drake's model of one scene: the contact parameters the adapter writes on the two
geometries, Drake's rules for combining them, and the law they make Drake integrate.

The derivation is in the docstring of `reference_impl.adapters.drake`; nothing here
loads Drake.
"""

from __future__ import annotations

import math

from reference_impl.adapters._records import AdapterScene, ImplementedLaw
from reference_impl.adapters.law_damping import implemented_law_from_table
from reference_impl.potentials.power import PowerLaw

__all__ = [
    "HC_MODES",
    "MODES",
    "combine",
    "drake_mapping",
    "split_stiffness",
]

# The plant's contact modes: the continuous (error-controlled) plant and the four
# approximations of the discrete plant (DiscreteContactApproximation).
MODES = ("continuous", "lagged", "similar", "tamsi", "sap")
# Modes whose dissipation is Hunt & Crossley's d (hunt_crossley_dissipation); SAP uses
# the linear Kelvin-Voigt relaxation time instead (relaxation_time).
HC_MODES = ("continuous", "lagged", "similar", "tamsi")


def combine(k1: float, k2: float, d1: float, d2: float, tau1: float, tau2: float) -> tuple:
    """Drake's combination of two geometries' point-contact parameters.

    Stiffnesses add in series, k = k1 k2 / (k1 + k2) (N/m); the Hunt-Crossley
    dissipation is the stiffness-weighted mean d = (k2 d1 + k1 d2) / (k1 + k2) (s/m),
    so the softer geometry's d dominates; SAP's relaxation times add, tau = tau1 + tau2
    (s). Measured on Drake 1.51 (verification/test_drake.py).

    Returns
    -------
    tuple of float
        (k, d, tau) of the contact.
    """
    k = k1 * k2 / (k1 + k2)
    d = (k2 * d1 + k1 * d2) / (k1 + k2)
    return k, d, tau1 + tau2


def split_stiffness(k: float, ratio: float) -> tuple[float, float]:
    """(k_ball, k_ground) (N/m) whose series combination is ``k``, with k_ground = ratio
    k_ball (``ratio`` > 0, dimensionless)."""
    k_ball = k * (1.0 + ratio) / ratio
    return k_ball, ratio * k_ball


def _refusal(scene: AdapterScene, mode: str, dissipation, relaxation_time) -> str | None:
    """Why ``mode`` cannot integrate the scene's law (one line), else None."""
    pot = scene.potential
    if type(pot) is not PowerLaw or pot.p != 1.0:
        return (
            "Drake's point contact is a linear spring k x (power p = 1); scene potential "
            f"{pot!r} has no equivalent"
        )
    if mode in HC_MODES and dissipation is None and scene.damping not in ("none", "hunt-crossley"):
        return (
            f"drake[{mode}] integrates the Hunt-Crossley law k x (1 + d xdot) and takes d, not "
            f"a restitution: the scene's {scene.damping!r} law has no d; run a scene with "
            "[damping] law = 'hunt-crossley' or give dissipation=D (s/m)"
        )
    if mode == "sap" and relaxation_time is None and scene.damping not in ("none", "universal"):
        return (
            "drake[sap] integrates a linear Kelvin-Voigt contact k (x + tau xdot) (the "
            f"universal law of p = 1) and takes tau: the scene's {scene.damping!r} law has no "
            "tau; give relaxation_time=TAU (s)"
        )
    return None


def drake_mapping(
    scene: AdapterScene,
    mode: str,
    *,
    dissipation: float | None = None,
    relaxation_time: float | None = None,
    ground_ratio: float = 1.0,
) -> dict:
    """Drake's parameters for one scene and the law they make it integrate.

    Parameters
    ----------
    scene : AdapterScene
        The run asked (a linear spring, p = 1).
    mode : str
        One of `MODES`.
    dissipation : float, optional
        Hunt-Crossley d (s/m) typed instead of the scene's alpha.
    relaxation_time : float, optional
        SAP's tau (s) typed instead of the scene's dashpot over its spring.
    ground_ratio : float, optional
        k_ground / k_ball (dimensionless, > 0): both geometries carry their own
        parameters and Drake combines them (`combine`).

    Returns
    -------
    dict
        ``declined`` (one line) or ``k``, ``d``, ``tau`` (the contact's), the per-geometry
        ``ball`` and ``ground`` (k, d, tau) and ``law`` (`ImplementedLaw`).
    """
    reason = _refusal(scene, mode, dissipation, relaxation_time)
    if reason:
        return {"declined": reason}
    m, k = float(scene.mass), float(scene.potential.k)
    alpha = float(scene.law.get("alpha", 0.0)) if scene.damping == "hunt-crossley" else 0.0
    d = alpha if dissipation is None else float(dissipation)
    if relaxation_time is not None:
        tau = float(relaxation_time)
    else:  # the scene's own dashpot c = 2 zeta sqrt(m k), typed as tau = c / k
        tau = (
            2.0 * float(scene.zeta or 0.0) * math.sqrt(m / k)
            if scene.damping == "universal"
            else 0.0
        )
    k_ball, k_ground = split_stiffness(k, ground_ratio)
    # the same d on both geometries is the contact's d under the weighted mean, and half
    # of tau on each is tau under the sum
    out = {
        "k": k,
        "d": d,
        "tau": tau,
        "ball": (k_ball, d, 0.5 * tau),
        "ground": (k_ground, d, 0.5 * tau),
    }
    pot = PowerLaw(k, 1.0)
    params = {"mode": mode, "k": k, "ball": list(out["ball"]), "ground": list(out["ground"])}
    if mode in HC_MODES:
        params["hunt_crossley_dissipation"] = d
        out["law"] = implemented_law_from_table(
            pot,
            m,
            {"law": "hunt-crossley", "alpha": d},
            clips_tension=True,
            description=f"Drake {mode} point contact: k x (1 + d xdot) clamped at 0, "
            f"k = {k:.7g} N/m, d = {d:.7g} s/m (Hunt-Crossley, alpha = d)",
            params=params,
        )
    else:
        c = k * tau
        zeta = c / (2.0 * math.sqrt(m * k))
        params["relaxation_time"] = tau
        out["law"] = ImplementedLaw(
            pot,
            m,
            zeta=zeta,
            clips_tension=True,
            description=f"Drake sap point contact: k (x + tau xdot) clamped at 0, k = {k:.7g} "
            f"N/m, tau = {tau:.7g} s (dashpot c = {c:.7g} N s/m, universal zeta = {zeta:.6g})",
            params=params,
        )
    return out
