"""Theorem 3 for the laws contact codes use: restitution against impact speed (issue 18).

Every law of `reference_impl.theory.laws` on one Hertz contact, each with its one strength
parameter calibrated so that the restitution at the overlap end (q = 0) is
``E_CAL`` at ``V_CAL``; then the restitution at both ends over impact speeds from
1e-3 to 1e2 m/s. The universal law is the exact quadrature (flat by Theorem 3);
the others come from `reference_impl.exact.general_law`. Shared by the benchmark
(`benchmarks/bench_exact.py`) and the report section (one home for the calibration).

The viscoelastic law is compared with the expansion of Schwager & Poeschel (1998),
1 - e = C1 A alpha^(2/5) v0^(1/5) - C2 A^2 alpha^(4/5) v0^(2/5) + ..., alpha = k / m,
C1 = Gamma(3/5) sqrt(pi) / (2^(1/5) 5^(2/5) Gamma(21/10)), C2 = (3/5) C1^2.
"""

from __future__ import annotations

import math
from functools import cache

import numpy as np

from reference_impl.errors import HCVInputError
from reference_impl.exact.api import solve
from reference_impl.potentials.power import PowerLaw
from reference_impl.scenes import law_for_restitution
from reference_impl.theory.laws import law_family, law_from_dict

__all__ = [
    "laws_results",
    "E_CAL",
    "V_CAL",
    "HERTZ",
    "STUDY_LAWS",
    "calibrated_laws",
    "law_from_strength",
    "restitution_curves",
    "schwager_poeschel",
]

E_CAL = 0.8  # restitution at the overlap end at the calibration speed
V_CAL = 1.0  # m/s
# Hertz contact of two 1 cm steel spheres (E* = 115 GPa, R* = 2.5 mm): k = 4/3 E* sqrt(R*),
# reduced mass of two 4.1 g spheres.
HERTZ = (4.0 / 3.0 * 115e9 * math.sqrt(2.5e-3), 1.5, 0.0041103 / 2)
STUDY_LAWS = ("universal", "linear", "power", "polynomial", "viscoelastic", "hunt-crossley")
# Exponent of the `power` law row (C = c q): Tsuji's q^(1/4) is the universal law itself.
POWER_EXPONENT = 1.0
SPEEDS = np.logspace(-3, 2, 26)  # m/s


def hertz():
    """The study's potential and reduced mass."""
    k, p, m = HERTZ
    return PowerLaw(k, p), m


def law_from_strength(name: str, g: float, pot, m: float) -> dict:
    """The law ``name`` with strength g (its registered strength parameter,
    `reference_impl.theory.laws.LawFamily.strength`; the study's shapes fixed here).

    ``power`` has exponent `POWER_EXPONENT`; ``polynomial`` is c = [g, g / q_ref] with
    q_ref the elastic overlap at V_CAL (equal constant and linear parts there).
    """
    fam = law_family(name)
    if name == "power":
        return {"law": "power", "c": g, "exponent": POWER_EXPONENT}
    if name == "polynomial":
        q_ref = pot.turning_point(0.5 * m * V_CAL**2)
        return {"law": "polynomial", "c": [g, g / q_ref]}
    if fam.strength is None:
        raise HCVInputError(f"damping law {name!r} has no strength to calibrate")
    return {"law": name, fam.strength: g}


@cache
def calibrated_laws(e_cal: float = E_CAL, v_cal: float = V_CAL) -> dict[str, dict]:
    """Each study law with its strength set so that e(v_cal) = e_cal at the overlap end,
    by the one solve-to-restitution of a law (`reference_impl.scenes.law_for_restitution`:
    closed form for the universal law, else a root on log(strength) to |e - e_cal| <= 1e-9)
    from the law at strength 1 in the study's shape (`law_from_strength`)."""
    pot, m = hertz()
    out = {}
    for name in STUDY_LAWS:
        unit = law_from_dict(law_from_strength(name, 1.0, pot, m))
        solved, _ = law_for_restitution(pot, m, unit, e_cal, v_cal, "overlap")
        out[name] = solved.to_dict()
    return out


def restitution_curves(speeds=SPEEDS) -> dict:
    """Restitution at both ends, each law, over ``speeds`` (m/s)."""
    pot, m = hertz()
    laws = calibrated_laws()
    curves = {}
    for name, law in laws.items():
        ov, zf, ret = [], [], []
        for v in speeds:
            s = solve(pot, m, float(v), law=law)
            ov.append(s.restitution)
            zf.append(s.restitution_zero_force)
            ret.append(bool(math.isfinite(s.contact_time)))
        curves[name] = {
            "law": law,
            "overlap": np.array(ov),
            "zero_force": np.array(zf),
            "returns": np.array(ret),
        }
    return {"speeds": np.asarray(speeds, float), "curves": curves, "m": m, "k": pot.k}


def schwager_poeschel(A: float, k: float, m: float, v0) -> np.ndarray:
    """Two-term expansion of 1 - e for the viscoelastic Hertz law (alpha = k / m)."""
    from scipy.special import gamma

    c1 = gamma(0.6) * math.sqrt(math.pi) / (2**0.2 * 5**0.4 * gamma(2.1))
    c2 = 0.6 * c1 * c1
    x = 1.5 * A * (k / m) ** 0.4 * np.asarray(v0, float) ** 0.2  # beta v0^(1/5)
    return c1 * x - c2 * x * x


def laws_results(quick: bool = False) -> dict:
    """Curves at both ends, drift per law and the Schwager-Poeschel comparison (JSON-safe)."""
    speeds = SPEEDS[::5] if quick else SPEEDS
    res = restitution_curves(speeds)
    v = res["speeds"]
    laws = []
    for name, c in res["curves"].items():
        row = {"law": name, "damping": c["law"]}
        for end in ("overlap", "zero_force"):
            e = c[end]
            row[end] = [float(x) for x in e]
            row[f"{end}_spread"] = float(e.max() - e.min())
            row[f"{end}_at_vmin"] = float(e[0])
            row[f"{end}_at_vmax"] = float(e[-1])
        row["returns"] = [bool(x) for x in c["returns"]]
        laws.append(row)
    A = calibrated_laws()["viscoelastic"]["A"]
    sp = schwager_poeschel(A, res["k"], res["m"], v)
    vis = res["curves"]["viscoelastic"]
    sp_rows = []
    for i in range(len(v)):
        sp_rows.append(
            {
                "v0": float(v[i]),
                "one_minus_e_expansion": float(sp[i]),
                "one_minus_e_overlap": float(1 - vis["overlap"][i]),
                "one_minus_e_zero_force": float(1 - vis["zero_force"][i]),
                "rel_dev_overlap": float(sp[i] / (1 - vis["overlap"][i]) - 1),
                "rel_dev_zero_force": float(sp[i] / (1 - vis["zero_force"][i]) - 1),
            }
        )
    return {
        "speeds": [float(x) for x in v],
        "e_cal": E_CAL,
        "v_cal": V_CAL,
        "hertz_k": HERTZ[0],
        "hertz_p": HERTZ[1],
        "mass": HERTZ[2],
        "laws": laws,
        "schwager_poeschel": sp_rows,
    }
