"""MuJoCo's model of one scene: the parameters the adapter writes (solref, solimp, radius),
the law they make MuJoCo integrate, and the model as MJCF text.

The derivation is in the docstring of `reference_impl.adapters.mujoco`; one adapter
configuration (solref form, impedance, integrator, calibration end and options) comes
in as keywords. Nothing here loads MuJoCo.
"""

from __future__ import annotations

import math

from reference_impl.adapters._asked import asked_universal_zeta
from reference_impl.adapters._codes_common import default_radius
from reference_impl.adapters._records import AdapterDeclined, AdapterScene, ImplementedLaw
from reference_impl.adapters.law_damping import LawDamping
from reference_impl.potentials.base import SumPotential
from reference_impl.potentials.power import PowerLaw
from reference_impl.theory.laws import DampingLaw

__all__ = ["asked_zeta", "mjcf", "scene_mapping"]

# MuJoCo's impedance clamp (mjMINIMP, mjMAXIMP) and default solimp / solref.
_MINIMP, _MAXIMP = 1e-4, 0.9999
_DEFAULT_SOLIMP = (0.9, 0.95, 0.001, 0.5, 2.0)


def _clamp_imp(x: float) -> float:
    return min(_MAXIMP, max(_MINIMP, float(x)))


def asked_zeta(scene: AdapterScene, end: str, dampratio, damping) -> float:
    """Damping ratio asked of MuJoCo at full impedance.

    Calibrated to the restitution the scene asks (``restitution_asked``, read at the
    scene's ``restitution_end``) so that the universal law's e at the adapter's ``end``
    is that value: ``overlap`` exp(-pi zeta / sqrt(1 - zeta^2)), ``zero-force``
    exp(-2 zeta s_peak) (what MuJoCo, which clips tension, delivers at both ends), by
    the helper every built-in adapter shares
    (`reference_impl.adapters._asked.asked_universal_zeta`). When the two ends agree
    this is the scene's own zeta, exactly.

    Raises
    ------
    AdapterDeclined
        A damping law other than the universal one (or none): MuJoCo's constant
        dashpot is not it, and treating it as undamped would score the wrong law.
    """
    reason = scene.universal_only("mujoco")
    if reason:
        raise AdapterDeclined(reason)
    if dampratio is not None:
        return dampratio
    if damping is not None:
        return damping / (2.0 * math.sqrt(scene.mass * scene.potential.k))
    return asked_universal_zeta(scene, end)


def scene_mapping(
    scene: AdapterScene,
    rho: float,
    *,
    form: str,
    impedance: str,
    integrator: str,
    end: str,
    dampratio,
    damping,
    imp: float,
    width,
    radius,
) -> dict:
    """MuJoCo parameters and the law it integrates for one scene.

    ``rho`` = m efc_diagA (1 for this model in every version measured; the
    run reads the real value and re-declares with it). ``form``, ``impedance``,
    ``integrator`` and ``end`` are one configuration of `MujocoAdapter`, the other
    keywords its options (``dampratio`` dimensionless, ``damping`` N s/m, ``imp``,
    ``width`` m, ``radius`` m; None: not given).
    """
    pot, m = scene.potential, scene.mass
    k = float(pot.k)
    w0 = math.sqrt(k / m)
    zeta = asked_zeta(scene, end, dampratio, damping)
    c = 2.0 * zeta * math.sqrt(m * k)
    vmax = max(scene.velocities or (scene.v0,))
    R = default_radius(scene, radius)
    if impedance == "constant":
        d = _clamp_imp(imp)
        solimp = (d, d, _DEFAULT_SOLIMP[2], _DEFAULT_SOLIMP[3], _DEFAULT_SOLIMP[4])
    else:
        w = width if width is not None else _DEFAULT_SOLIMP[2]
        solimp = (
            _clamp_imp(_DEFAULT_SOLIMP[0]),
            _clamp_imp(_DEFAULT_SOLIMP[1]),
            w,
            _clamp_imp(_DEFAULT_SOLIMP[3]),
            max(1.0, _DEFAULT_SOLIMP[4]),
        )
    dw = solimp[1]
    out: dict = {"R": R, "solimp": solimp, "zeta_asked": zeta, "clamped": False}
    if form == "direct":
        S, D = k / m, c / m
        out["solref"] = (-S, -D)
        K, B = S / dw**2, D / dw
    else:
        tc, dr = 1.0 / (w0 * zeta) if zeta > 0 else math.inf, zeta
        tc_used = max(tc, 2.0 * scene.dt)  # MuJoCo's refsafe clamp (positive form only)
        out["clamped"] = tc_used > tc
        out["solref"] = (tc_used, dr)
        if zeta > 0:
            K, B = 1.0 / (dw**2 * tc_used**2 * dr**2), 2.0 / (dw * tc_used)
        else:  # declined in supports(); keep the mapping defined
            K, B = k / m / dw**2, 0.0
    out["K"], out["B"] = K, B
    how = (
        f"dampratio {dampratio!r} given"
        if dampratio is not None
        else f"damping {damping!r} N s/m given"
        if damping is not None
        else f"calibrated at the {end} end"
    )
    head = (
        f"MuJoCo solref {form} {out['solref'][0]!r} {out['solref'][1]!r}"
        + (" (timeconst clamped to 2 timestep)" if out["clamped"] else "")
        + f", {integrator}, zeta asked {zeta:.6g} ({how})"
    )
    if impedance == "constant":
        d = solimp[0]
        g = d / (d + rho * (1.0 - d))
        k_eff, c_eff = m * g * K * d, m * g * B
        z_eff = c_eff / (2.0 * math.sqrt(m * k_eff))
        out["law"] = ImplementedLaw(
            PowerLaw(k_eff, 1.0),
            m,
            zeta=z_eff,
            clips_tension=True,
            description=f"{head}; constant impedance {d:g}: linear spring k = {k_eff:.7g} "
            f"N/m, dashpot c = {c_eff:.7g} N s/m (universal law zeta = {z_eff:.6g}), "
            "tension clipped",
        )
        return out
    dmin, dmax, w, mid, power = solimp
    if rho != 1.0:
        out["declined"] = (
            f"default impedance with m efc_diagA = {rho!r} != 1: MuJoCo's law is not a "
            "sum of powers the suite can declare"
        )
        return out
    if power != 2.0:  # pragma: no cover - the default solimp has power 2
        out["declined"] = "default impedance declared for solimp power 2 only"
        return out
    # I(q) = dmin + (dmax - dmin) q^2 / (mid w^2) for q <= mid w (power 2).
    a0, a2 = dmin, (dmax - dmin) / (mid * w * w)
    terms = [(m * K * a0 * a0, 1.0), (2.0 * m * K * a0 * a2, 3.0), (m * K * a2 * a2, 5.0)]
    elastic = SumPotential(*(PowerLaw(kk, pp) for kk, pp in terms))
    q_law = float(elastic.turning_point(0.5 * m * vmax * vmax))
    if q_law > mid * w:
        out["declined"] = (
            f"default impedance: the overlap reaches {q_law:.4g} m at v0 = {vmax:g} m/s, "
            f"past solimp's midpoint x width = {mid * w:.4g} m where MuJoCo's impedance "
            f"switches to its second polynomial piece; give width >= {q_law / mid:.3g}"
        )
        return out
    coeffs = [m * B * a0, 0.0, m * B * a2]
    damp = LawDamping(DampingLaw("polynomial", {"c": coeffs}), elastic, m)
    out["law"] = ImplementedLaw(
        elastic,
        m,
        C=damp,
        clips_tension=True,
        description=f"{head}; default impedance solimp {solimp}: U' = "
        + " + ".join(f"{kk:.6g} q^{pp:g}" for kk, pp in terms)
        + f", C = {coeffs[0]:.6g} + {coeffs[2]:.6g} q^2 (polynomial), tension clipped",
    )
    return out


def mjcf(mp: dict, scene: AdapterScene, integrator: str) -> str:
    """The model of `scene_mapping` ``mp`` as MJCF text (numbers as ``repr(float(x))``)."""

    def num(x) -> str:
        return repr(float(x))

    solref = f"{num(mp['solref'][0])} {num(mp['solref'][1])}"
    solimp = " ".join(num(x) for x in mp["solimp"])
    R = mp["R"]
    size = num(10.0 * R)
    contact = f'condim="1" solref="{solref}" solimp="{solimp}" margin="0" gap="0"'
    inertia = num(0.4 * scene.mass * R * R)
    return (
        "<mujoco>\n"
        f'  <option timestep="{num(scene.dt)}" gravity="0 0 0" '
        f'integrator="{integrator}"/>\n'
        "  <worldbody>\n"
        f'    <geom name="plane" type="plane" size="{size} {size} {size}" {contact}/>\n'
        f'    <body name="ball" pos="0 0 {num(R)}">\n'
        '      <joint name="z" type="slide" axis="0 0 1"/>\n'
        f'      <inertial pos="0 0 0" mass="{num(scene.mass)}" '
        f'diaginertia="{inertia} {inertia} {inertia}"/>\n'
        f'      <geom name="ball" type="sphere" size="{num(R)}" mass="0" {contact}/>\n'
        "    </body>\n"
        "  </worldbody>\n"
        "</mujoco>\n"
    )
