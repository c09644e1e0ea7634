"""Tool tests of the one mpmath inverse of U (`reference_impl.exact._truth.MpInverse`).

Until issue 16 it was written twice: `solve_impact_mp`'s (a float inverse per call) and
the work-precision study's trajectory truth (a table seed). Both now call `MpInverse`;
the study's truths are the floats they were before (recorded below at commit 2065532,
the 30-digit truth rounded to float64: a correct inverse gives these floats exactly).
"""

from __future__ import annotations

import mpmath
import numpy as np
import pytest

from reference_impl.exact._truth import MpInverse
from reference_impl.potentials import PowerLaw
from reference_impl.studies.workprecision import _TRUTH_CACHE, default_scenes, ground_truth
from verification.assertions import assert_true

# Three of the study's scenes (the other three take 2-8 s each): a closed-form inverse,
# the ellipsoid, and a sum of power laws (numeric float inverse: the table seed at work).
# Per scene: contact time, restitution, max penetration, then t_samples and q_samples.
OLD_TRUTHS = {
    "hertz-k1e9-damped": (
        (9.727426840603931e-05, 0.526620599330303, 2.4364471042771238e-05),
        (
            9.992703873929066e-06, 1.750457996307953e-05, 2.4388361525548214e-05,
            3.096223585533421e-05, 3.738006057369071e-05, 4.374240532856007e-05,
            5.01298808270726e-05, 5.6619138698347384e-05, 6.329557388250237e-05,
            7.027082821447543e-05, 7.772080278554498e-05, 8.601335870824008e-05,
        ),
        (
            9.484345390534477e-06, 1.5504127399659215e-05, 1.9807440768652268e-05,
            2.2632250144065505e-05, 2.409524838317538e-05, 2.4299369909744067e-05,
            2.3359116791748962e-05, 2.1405019346808975e-05, 1.8579531692129045e-05,
            1.5026512811199573e-05, 1.0869260059916705e-05, 6.144447307216321e-06,
        ),
    ),
    "paper-ellipsoid": (
        (0.019404172873400558, 1.0, 0.0067069917600942296),
        (
            0.0024959075307984446, 0.004043171745317987, 0.005402539443601844,
            0.006674179463368344, 0.007900163638131391, 0.009103704155592954,
            0.010300468717807605, 0.011504009235269168, 0.012729993410032215,
            0.014001633429798713, 0.015361001128082571, 0.016908265342602116,
        ),
        (
            0.0024526292437446248, 0.0038833656838788, 0.004989574466244775,
            0.005823280296380927, 0.006386517924105177, 0.006671237229799674,
            0.006671237229799674, 0.006386517924105177, 0.005823280296380927,
            0.004989574466244775, 0.0038833656838788, 0.0024526292437446248,
        ),
    ),
    "power-sum-damped": (
        (0.014420603102227116, 0.526620599330303, 0.0010574758306950806),
        (
            0.001307114057231923, 0.002438100847392485, 0.0035045737298821287,
            0.004536789118222354, 0.005551152392316396, 0.006559071666498542,
            0.007569916509583871, 0.008592505407384819, 0.009636251585885498,
            0.010712594600773062, 0.011837758749919271, 0.013040755337378546,
        ),
        (
            0.0003706936725575187, 0.0006424028199641807, 0.0008423188514906645,
            0.0009753345606291272, 0.001044683151312283, 0.00105438155640417,
            0.0010097529271104904, 0.0009173949443928071, 0.0007849075010930308,
            0.0006204583628205392, 0.0004321213276619772, 0.00022648276163013308,
        ),
    ),
}  # fmt: skip


@pytest.mark.parametrize("name", sorted(OLD_TRUTHS))
def test_study_truth_is_the_old_one(name):
    sc = next(s for s in default_scenes() if s.name == name)
    _TRUTH_CACHE.clear()  # computed here, with the inverse of this tree
    g = ground_truth(sc)
    got = (
        (g.contact_time, g.restitution, g.max_penetration),
        tuple(g.t_samples.tolist()),
        tuple(g.q_samples.tolist()),
    )
    assert_true(
        got == OLD_TRUTHS[name],
        got=str(got),
        should=f"the floats of the old truth {OLD_TRUTHS[name]}",
        claim="tool",
        call=f"ground_truth({name})",
    )


@pytest.mark.parametrize("name", [s.name for s in default_scenes()])
def test_both_seeds_give_the_same_inverse(name):
    """With a seed table or a float inverse per call: U(q) = u and the same q to the
    working precision, from 1e-60 of the peak energy to the peak."""
    sc = next(s for s in default_scenes() if s.name == name)
    pot = sc.potential
    u_max = 0.5 * sc.m * sc.v0**2
    with mpmath.workdps(40):
        per_call, table = MpInverse(pot), MpInverse(pot, u_max)
        for uf in u_max * np.geomspace(1e-60, 1.0, 7):
            u = mpmath.mpf(uf)
            q1, q2 = per_call(u), table(u)
            # 1e-35: the working precision (40 digits) less the Newton step's tolerance. U(q)
            # is checked with 60 more digits: the saturating force's q_s F0 (x - atan x)
            # loses 2 log10(1/x) digits to cancellation (40 at u = 1e-60 u_max, x = 1e-20).
            with mpmath.workdps(100):
                resid = abs(pot._U(q1) / u - 1)
            ok = abs(q1 / q2 - 1) < mpmath.mpf(10) ** -35 and resid < 1e-35
            assert_true(
                ok,
                got=f"q = {mpmath.nstr(q1, 20)} and {mpmath.nstr(q2, 20)}",
                should="the same q with U(q) = u to 35 digits",
                claim="tool",
                call=f"MpInverse({name})({uf:.3g})",
            )


def test_energy_outside_the_float_range_is_seeded_by_the_power_law():
    pot = PowerLaw(1e9, 1.5)
    with mpmath.workdps(40):
        u = mpmath.mpf("1e-400")  # below the smallest float: no float seed
        q = MpInverse(pot)(u)
        exact = (u * mpmath.mpf(2.5) / mpmath.mpf(1e9)) ** (1 / mpmath.mpf(2.5))
        # 1e-35: the working precision (40 digits) less the Newton step's tolerance
        assert_true(
            abs(q / exact - 1) < mpmath.mpf(10) ** -35,
            got=mpmath.nstr(q, 30),
            should=mpmath.nstr(exact, 30),
            claim="tool",
            call="MpInverse(PowerLaw(1e9, 1.5))(1e-400)",
        )
