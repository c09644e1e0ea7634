"""The ``[damping]`` table of a scene: the law, its parameters, and a restitution asked
at a speed, whose strength is solved once the potential and mass are known (issue 26).
Private to the scenes package (`_scene.scene_from_dict` calls `_damping` and
`_solve_strength`)."""

from __future__ import annotations

import math
import sys

from reference_impl.errors import HCVInputError
from reference_impl.potentials import PowerLaw
from reference_impl.scenes._fields import _keys, _number, _string, _table, _Where
from reference_impl.scenes._law_restitution import law_for_restitution, speed_dependent_laws
from reference_impl.theory.damping import zeta_from_restitution
from reference_impl.theory.laws import LAWS, DampingLaw, law_family, law_from_dict

__all__: list[str] = []  # private to the scenes package

_LAWS = LAWS
_ENDS = ("overlap", "zero-force")
# The keys of ``[damping]`` besides the laws' own parameters (`_damping_keys`).
_FORM_KEYS = (
    "law",
    "zeta",
    "restitution",
    "restitution_end",
    "restitution_speed",
    "C0",
    "K",
    "M",
)


def _law_keys() -> tuple[str, ...]:
    """Every parameter key of every registered law, in registration order."""
    return tuple(dict.fromkeys(p.key for f in LAWS.values() for p in f.params))


def _damping_keys() -> tuple[str, ...]:
    return tuple(dict.fromkeys((*_FORM_KEYS, *_law_keys())))


def _damping(err: _Where, table) -> tuple[str, float | None, DampingLaw, dict | None]:
    """(law name, zeta of the universal law or None, DampingLaw, restitution request or
    None) from ``[damping]``; a request is solved by `_solve_strength` once U and m are known."""
    table = _table(err, table, "damping")
    _keys(err, table, "damping.", _damping_keys())
    law = _string(err, table.get("law", "none"), "damping.law", _LAWS)
    if law != "universal":
        return _other_law(err, law, table)
    if "restitution_speed" in table:
        raise err(
            "damping.restitution_speed: the universal law's restitution does not depend on "
            "the impact speed (Theorem 3); remove it"
        )
    other = [k for k in _law_keys() if k in table and k not in _FORM_KEYS]
    if other:
        raise err(f"damping.{other[0]} does not belong to law = 'universal'; remove it")
    forms = [k for k in ("zeta", "restitution", "C0") if k in table]
    if len(forms) != 1:
        what = "none" if not forms else " and ".join(forms)
        raise err(
            f"damping.law = 'universal' needs exactly one of zeta, restitution or C0 "
            f"(with K and M), got {what}"
        )
    if forms[0] != "C0" and ("K" in table or "M" in table):
        raise err("damping.K and damping.M go with damping.C0 only; remove them")
    if "restitution_end" in table and forms[0] != "restitution":
        raise err("damping.restitution_end goes with damping.restitution only; remove it")
    if forms[0] == "zeta":
        zeta = _number(err, table["zeta"], "damping.zeta", low=0.0, strict=False)
    elif forms[0] == "restitution":
        e = _number(err, table["restitution"], "damping.restitution", low=0.0, high=1.0)
        end = _string(
            err, table.get("restitution_end", "overlap"), "damping.restitution_end", _ENDS
        )
        try:
            zeta = zeta_from_restitution(e, end=end)
        except HCVInputError as exc:
            raise err(f"damping.restitution = {e!r}: {exc}") from None
    else:
        for key in ("K", "M"):
            if key not in table:
                raise err(
                    f"damping.C0 needs damping.{key} too (zeta = C0 / (2 sqrt(K M)), section 8)"
                )
        c0 = _number(err, table["C0"], "damping.C0", low=0.0, strict=False)
        K = _number(err, table["K"], "damping.K", low=0.0)
        M = _number(err, table["M"], "damping.M", low=0.0)
        zeta = c0 / (2.0 * math.sqrt(K * M))
    return law, zeta, DampingLaw("universal", {"zeta": zeta}), None


def _other_law(err: _Where, law: str, table: dict) -> tuple[str, None, DampingLaw, dict | None]:
    """(law, None, DampingLaw, request) of a law other than 'universal'; with
    ``restitution`` (and ``restitution_speed``) the law is at unit strength and the request
    says what to solve its strength for (`_solve_strength`)."""
    only_universal = [k for k in ("zeta", "C0", "K", "M") if k in table]
    asked_keys = [k for k in ("restitution", "restitution_end", "restitution_speed") if k in table]
    if law == "none" and asked_keys and not only_universal:
        # not 'universal' only: restitution_speed belongs to the speed-dependent laws
        raise err(
            f"damping.{asked_keys[0]}: damping.law is 'none', which takes no restitution (e = 1); "
            "for a restitution choose law = 'universal' (restitution, optional "
            f"restitution_end) or a speed-dependent law ({', '.join(speed_dependent_laws())}: "
            "restitution "
            "with restitution_speed), or remove it"
        )
    if only_universal:
        raise err(
            f"damping.{only_universal[0]} belongs to law = 'universal', but damping.law is "
            f"{law!r}; remove it or change the law"
        )
    asked = {k: table[k] for k in ("restitution", "restitution_end", "restitution_speed")
             if k in table}  # fmt: skip
    if asked and "restitution" not in asked:
        first = next(iter(asked))
        raise err(f"damping.{first} goes with damping.restitution only; remove it")
    rest = {k: v for k, v in table.items() if k not in asked}
    request = None
    if asked:
        fam = law_family(law)
        if law not in speed_dependent_laws():
            raise err(
                f"damping.restitution: law = {law!r} has no strength to solve from a "
                f"restitution; choose one of {', '.join(speed_dependent_laws())} or remove it"
            )
        key = fam.strength
        if "restitution_speed" not in asked:
            raise err(
                f"damping.restitution with law = {law!r} needs damping.restitution_speed = v "
                "[m/s]: this law's restitution depends on the impact speed (only 'universal' "
                "does not)"
            )
        if key in rest and not fam.shape_scaled:
            raise err(
                f"damping.{key} and damping.restitution both set the strength of law = "
                f"{law!r}; give one of them"
            )
        e = _number(err, asked["restitution"], "damping.restitution", low=0.0, high=1.0)
        v = _number(err, asked["restitution_speed"], "damping.restitution_speed", low=0.0)
        end = _string(
            err, asked.get("restitution_end", "overlap"), "damping.restitution_end", _ENDS
        )
        if not fam.shape_scaled:
            rest[key] = 1.0  # unit strength, solved below once U and m are known
        elif key not in rest:
            raise err(
                f"damping.restitution with law = {law!r} needs damping.{key} = [c0, c1, ...]: "
                "its shape (all coefficients are scaled to give the restitution)"
            )
        request = {"restitution": e, "restitution_speed": v, "restitution_end": end}
    try:
        dl = law_from_dict(rest, where="damping")
    except HCVInputError as exc:
        raise err(str(exc)) from None
    return law, None, dl, request


def _solve_strength(err: _Where, potential, mass: float, dlaw: DampingLaw, request: dict):
    """(solved law, calibration record) of a restitution request (`law_for_restitution`)."""
    _check_speed(err, potential, mass, request["restitution_speed"])
    try:
        solved, s = law_for_restitution(
            potential,
            mass,
            dlaw,
            request["restitution"],
            request["restitution_speed"],
            request["restitution_end"],
        )
    except HCVInputError as exc:
        raise err(f"damping.restitution = {request['restitution']!r}: {exc}") from None
    fam = dlaw.family
    key = fam.strength
    value = list(solved.params[key]) if fam.shape_scaled else solved.params[key]
    record = {**request, "parameter": key, "value": value}
    if fam.shape_scaled:
        record["scale"] = s
    return solved, record


def _check_speed(err: _Where, potential, mass: float, v: float) -> None:
    """Refuse a ``restitution_speed`` whose impact the exact solver cannot represent, in a
    line naming it: m v^2 / 2 must be a positive normal float64 (the solvers' own check,
    which would otherwise fail inside the strength search naming v0), and U must reach it."""
    tiny, huge = sys.float_info.min, sys.float_info.max
    energy = 0.5 * mass * v * v
    if not (math.isfinite(energy) and energy >= tiny):
        # the speeds whose energy is in range, for this mass (sqrt(2 huge) overflows: split)
        v_lo = math.sqrt(2.0 / mass) * math.sqrt(tiny)
        v_hi = math.sqrt(2.0 / mass) * math.sqrt(huge)
        raise err(
            f"damping.restitution_speed = {v!r}: the kinetic energy m v^2 / 2 = {energy!r} J "
            f"(m = {mass!r} kg) must be a positive normal float64 in [{tiny:.3g}, {huge:.3g}] J, "
            f"i.e. {v_lo:.3g} < v < {v_hi:.3g} m/s; rescale the units (e.g. mm, g, ms)"
        )
    try:
        potential.turning_point(energy)
    except HCVInputError as exc:
        raise err(f"damping.restitution_speed = {v!r} m/s (E = {energy:.6g} J): {exc}") from None


def _universal_zeta(potential, mass: float, law: DampingLaw) -> float | None:
    """The zeta of the universal law whose C(q) is this law's, or None when none is.

    C(q) = 0 (law 'none', or a law at strength 0, e.g. solved for e = 1) is the universal
    law at zeta = 0. On a Hooke potential (family power, p = 1: U = k q^2 / 2) the universal
    C = 2 zeta sqrt(m) U' / sqrt(2 U) = 2 zeta sqrt(m k) is a constant, so a law whose C is
    the constant c (linear c; power with exponent 0; a polynomial [c0]; viscoelastic
    A U'' = A k) is the universal law at zeta = c / (2 sqrt(m k)), exactly. Other potentials
    (a sum or an expression that happens to be Hooke included) are not recognised.
    """
    if law.harmonic_zeta is not None:
        return law.harmonic_zeta
    if law.route != "general":
        return None  # a generic C(q, q'): not recognised
    if law.is_zero():
        return 0.0
    if type(potential) is not PowerLaw or potential.p != 1.0:
        return None
    k = potential.k
    d = law.decomposition()
    # constant terms and A U'' = A k only (alpha U' and a universal part are not constant)
    if d.alpha or d.zeta or not all(e == 0.0 for _, e in d.terms):
        return None
    # (bit for bit the sums of before: A k alone, or the constant terms + 0.0)
    c = d.A * k if not d.terms else sum(c for c, _ in d.terms) + d.A * k
    return c / (2.0 * math.sqrt(mass * k))
