"""Work-precision study: every potential family is in it, and the exact solver's
row of each is within the solver's own error bound.

One quick study (the scenes ``hcv report --quick`` runs, without Verlet points:
the exact solver, DOP853 and RK45 at three tolerances, ~20 s) is computed once
per module; the 30-digit truths are cached per process by
`reference_impl.studies.workprecision.ground_truth`.
"""

from __future__ import annotations

import math

import pytest

from reference_impl.potentials import FAMILIES
from reference_impl.report._wp import METRICS, wp_figures, wp_overview_figure
from reference_impl.studies.workprecision import default_scenes, family_scenes, work_precision
from reference_impl.studies.wp_summary import (
    FAMILY_NAMES,
    QUICK_SKIP,
    family_summary,
    scene_families,
)
from verification.assertions import assert_less, assert_true

CALL = "work_precision(quick=True)"
CLAIM = "work-precision"


@pytest.fixture(scope="module")
def study():
    scenes = [s for s in default_scenes() if s.name not in QUICK_SKIP]
    return work_precision(scenes, quick=True, methods=("DOP853", "RK45"))


def test_every_family_has_a_scene(study):
    fams = scene_families()
    present = {fams[s] for s in set(study.scene)}
    assert_true(
        present == set(FAMILY_NAMES.values()),
        got=f"families {sorted(present)}",
        should=f"every family {sorted(FAMILY_NAMES.values())}",
        claim=CLAIM,
        call=CALL,
    )


@pytest.mark.parametrize("family", sorted(FAMILIES))
def test_every_registered_family_has_a_study_scene(family):
    """The study's families are the registry's: a new family fails here until it has a scene
    (no list to edit), and `FAMILY_NAMES` only names registered ones."""
    have = {s.potential.family for s in default_scenes()}
    assert_true(
        family in have and set(FAMILY_NAMES) <= set(FAMILIES),
        got=f"study families {sorted(have)}, FAMILY_NAMES {sorted(FAMILY_NAMES)}",
        should=f"a scene of {family!r}, and only registered names in FAMILY_NAMES",
        claim=CLAIM,
        call="default_scenes()",
    )


@pytest.mark.parametrize("scene", [s.name for s in default_scenes() if s.name not in QUICK_SKIP])
def test_exact_row_within_own_bound(study, scene):
    ex = study[(study.scene == scene) & (study.method == "exact")]
    assert_true(
        len(ex) == 1,
        got=f"{len(ex)} exact rows",
        should="one exact-solver row",
        claim=CLAIM,
        call=f"{CALL} [{scene}]",
    )
    row = ex.iloc[0]
    bound = float(row.contact_time_bound)
    assert_true(
        math.isfinite(bound) and bound > 0,
        got=f"bound {bound!r}",
        should="a finite positive contact-time bound",
        claim=CLAIM,
        call=f"{CALL} [{scene}]",
    )
    # Tolerance: the solver's own quadrature_error (relative to t_c); the truth's
    # error (30 digits) is negligible against it.
    assert_less(
        float(row.err_contact_time),
        bound,
        claim=CLAIM,
        call=f"{CALL} [{scene}]",
        what="relative contact-time error of the exact solver",
    )


def test_family_scenes_run_only_runge_kutta(study):
    fam = {s.name for s in family_scenes()} - {"hertz-k1e9-damped"}
    methods = set(study[study.scene.isin(fam)].method)
    assert_true(
        methods == {"exact", "DOP853", "RK45"},
        got=f"methods {sorted(methods)}",
        should="exact, DOP853 and RK45 on the added family scenes",
        claim=CLAIM,
        call=CALL,
    )


def test_family_summary_and_overview(study, tmp_path):
    rows = study.to_dict("records")
    summ = family_summary(rows)
    assert_true(
        {x["scene"] for x in summ} == set(study.scene)
        and all(
            math.isfinite(x["exact_seconds"])
            and math.isfinite(x["dop853_seconds"])
            and x["dop853_setting"].startswith("rtol=")
            for x in summ
        ),
        got=f"{summ}",
        should="one line per scene with measured exact and DOP853 times",
        claim=CLAIM,
        call="family_summary",
    )
    pytest.importorskip("matplotlib")
    name, caption = wp_overview_figure(study, tmp_path, scene_families())
    assert_true(
        (tmp_path / name).stat().st_size > 10_000 and "per potential family" in caption,
        got=f"{name} ({(tmp_path / name).stat().st_size} bytes)",
        should="a drawn overview figure",
        claim=CLAIM,
        call="wp_overview_figure",
    )


def test_a_users_ode_solver_joins_the_study_by_class(study):
    """As scipy accepts an OdeSolver subclass for ``method``, so does the study's registry."""
    from scipy.integrate import RK45

    class MyRK45(RK45):
        """A user's integrator: here RK45 itself, so its rows must equal RK45's."""

    sc = [s for s in default_scenes() if s.name not in QUICK_SKIP][0]
    mine = work_precision([sc], quick=True, methods=[MyRK45])
    ref = study[(study.scene == sc.name) & (study.method == "RK45")]
    got = mine[mine.method == "MyRK45"]
    assert_true(
        len(got) == len(ref) > 0 and list(got.err_contact_time) == list(ref.err_contact_time),
        got=list(got.err_contact_time),
        should=list(ref.err_contact_time),
        claim=CLAIM,
        call="work_precision(methods=[MyRK45])",
    )


def test_every_study_scene_is_the_catalogue_scene_of_its_name():
    """Issue 17: a name the README's speed table or the report shows is one scene in every
    command (the study's Hertz rows were once a different 'hertz-damped' than the bench's)."""
    from reference_impl.scenes import load_scene
    from reference_impl.scenes._scene import potential_to_dict

    for sc in default_scenes() + family_scenes():
        cat = load_scene(sc.name)
        assert_true(
            cat.mass == sc.m
            and sc.v0 in cat.velocities
            and (cat.zeta or 0.0) == sc.zeta
            and potential_to_dict(cat.potential) == potential_to_dict(sc.potential),
            got=f"catalogue {sc.name}: m={cat.mass}, v0={cat.velocities}, zeta={cat.zeta}, "
            f"{potential_to_dict(cat.potential)}",
            should=f"m={sc.m}, v0={sc.v0}, zeta={sc.zeta}, {potential_to_dict(sc.potential)}",
            claim=CLAIM,
            call=f"load_scene({sc.name!r})",
        )


def test_a_method_without_a_style_fails_the_plots(tmp_path):
    """A study row of a method the plots have no style for is an error, never a curve
    silently left out (a user's solver joins the study by class, see above)."""
    pytest.importorskip("matplotlib")
    import pandas as pd

    row = {"scene": "hertz-k1e9", "method": "MyRK45", "setting": "rtol=1e-06", "seconds": 1e-3}
    df = pd.DataFrame([{**row, **{col: 1e-6 for col, _ in METRICS}}])
    for name, plot in (
        ("wp_overview_figure", lambda: wp_overview_figure(df, tmp_path, {"hertz-k1e9": "p"})),
        (
            "wp_figures",
            lambda: wp_figures(df, tmp_path, {"hertz-k1e9": "hertz-k1e9"}, {"hertz-k1e9": "p"}),
        ),
    ):
        with pytest.raises(ValueError, match="MyRK45"):
            plot()
            pytest.fail(f"got a figure, should be ValueError naming MyRK45 [tool, {name}]")
