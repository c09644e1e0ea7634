"""What a code is asked to deliver (protocol ``hcv-adapter/2``): the universal law's
damping ratio whose restitution, at the end where the code's contact ends, is the
restitution the scene asks at the end it names; and the input of a code whose
damping input passes through a fixed decreasing map of its own (a fit alpha(e),
beta(e), gamma(e)).

One helper for every built-in adapter (LAMMPS, Kratos, LIGGGHTS, YADE, MuJoCo), so
that they read the request the same way.

Why the end of a code's contact matters: a code that clips tension (sets a pulling
total force to 0) ends the contact where U' + C q' first vanishes, then flies freely
with that speed, so its restitution is the universal law's zero-force one,
exp(-2 zeta s_peak), whichever end it is read at; a code that lets the damper pull
delivers exp(-pi zeta / sqrt(1 - zeta^2)) at q = 0 and the zero-force one at the
zero-force end. Either way the zeta to ask is the one whose restitution at the end the
code delivers at equals the asked e.
"""

from __future__ import annotations

from collections.abc import Callable

from scipy.optimize import brentq

from reference_impl.adapters._records import AdapterScene
from reference_impl.theory.damping import zeta_from_restitution

__all__ = ["asked_universal_zeta", "delivery_end", "invert_decreasing"]


def delivery_end(scene: AdapterScene, clips_tension: bool) -> str:
    """The end at which a code's restitution must equal the asked one for the scene.

    Parameters
    ----------
    scene : AdapterScene
        The run asked.
    clips_tension : bool
        Whether the code sets an attractive total normal force to 0.

    Returns
    -------
    str
        ``"zero-force"`` for a code that clips tension (its restitution is the law's
        zero-force one at both ends), else the scene's ``restitution_end``.
    """
    return "zero-force" if clips_tension else scene.restitution_end


def asked_universal_zeta(scene: AdapterScene, end: str) -> float:
    """Damping ratio of the universal law whose restitution at ``end`` is the asked one.

    Parameters
    ----------
    scene : AdapterScene
        A scene of the universal law or of none (a code that maps only these declines
        the others before asking).
    end : {"overlap", "zero-force"}
        The end at which the code's restitution is to equal ``scene.restitution_asked``
        (see `delivery_end`).

    Returns
    -------
    float
        zeta (dimensionless, >= 0): 0 without damping or for an asked e >= 1; the
        scene's own zeta, exactly, when ``end`` is the scene's ``restitution_end``;
        else `reference_impl.theory.damping.zeta_from_restitution` of the asked e at
        ``end`` (closed form at the overlap end, inverted to a few ulps at the
        zero-force end).
    """
    if scene.damping != "universal" or not scene.zeta:
        return 0.0
    e = float(scene.restitution_asked)
    if e >= 1.0:
        return 0.0
    if end == scene.restitution_end:
        return float(scene.zeta)
    return float(zeta_from_restitution(e, end=end))


def invert_decreasing(f: Callable[[float], float], target: float, lo: float, hi: float) -> float:
    """x in [lo, hi] with f(x) = target for a continuous decreasing f (a code's own map).

    Parameters
    ----------
    f : callable
        Decreasing on [lo, hi], e.g. a code's damping ratio as a function of its
        restitution input.
    target : float
        The value asked of f.
    lo, hi : float
        The input range the code accepts.

    Returns
    -------
    float
        The root to brentq's tolerance (2e-15 relative in x); ``lo`` when target >=
        f(lo) and ``hi`` when target <= f(hi): the nearest input the code takes (what
        it then delivers is its declared law's, shown by the delivery verdict).
    """
    f_lo, f_hi = f(lo), f(hi)
    if target >= f_lo:
        return lo
    if target <= f_hi:
        return hi
    return float(brentq(lambda x: f(x) - target, lo, hi, xtol=1e-300, rtol=8.9e-16, maxiter=500))
