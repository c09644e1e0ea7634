"""``hcv report``: the work done in background processes comes back as if done here.

`reference_impl.campaign._truths` queues the study's 30-digit truths behind the critical-
step map's searches and hands them to the timed study before its first timing. Checked
here on the cheapest scene of the study: the truth that comes back from a worker is bit for
bit the one computed here, and the study then uses it instead of computing it again.
`reference_impl.campaign._drawing` draws a figure in a forked process: its file and return
value are those drawn here; a worker that dies leaves the drawing to this process, and a
drawing that raises raises here.
"""

from __future__ import annotations

import multiprocessing as mp
import os
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest

from reference_impl.campaign import _drawing, _truths
from reference_impl.studies import workprecision as wp
from reference_impl.studies.wp_summary import QUICK_SKIP, report_scenes

CALL = "_truths.collect_truths(_truths.submit_truths(pool, quick=True), quick=True)"


@pytest.fixture
def one_scene(monkeypatch):
    """The study's undamped Hertz scene alone (its truth takes ~1 s), as the report's list."""
    sc = next(s for s in wp.default_scenes() if s.name == "hertz-k1e9")
    monkeypatch.setattr(_truths, "report_scenes", lambda quick: [sc])
    monkeypatch.setattr(wp, "_TRUTH_CACHE", {})
    return sc


@pytest.mark.skipif("fork" not in mp.get_all_start_methods(), reason="the report forks")
def test_a_background_truth_is_the_one_computed_here_and_is_not_computed_again(
    one_scene, monkeypatch
):
    with ProcessPoolExecutor(1, mp_context=mp.get_context("fork")) as pool:
        _truths.collect_truths(_truths.submit_truths(pool, quick=True), quick=True)
    kept = wp.ground_truth(one_scene)  # the kept one (the cache was empty before)

    def computed_again(*args, **kw):
        raise AssertionError(f"got a truth computed again, should be the kept one [{CALL}]")

    monkeypatch.setattr(wp, "solve_impact_mp", computed_again)
    assert wp.ground_truth(one_scene) is kept, f"got another truth, should be the kept one [{CALL}]"
    monkeypatch.undo()  # the truth of this process, from an empty cache
    monkeypatch.setattr(wp, "_TRUTH_CACHE", {})
    here = wp.ground_truth(one_scene)
    for field in ("contact_time", "restitution", "max_penetration", "t_samples", "q_samples"):
        got, want = np.asarray(getattr(kept, field)), np.asarray(getattr(here, field))
        assert np.array_equal(got, want), (
            f"got {field} {got!r}, should be {want!r} bit for bit (computed here) [{CALL}]"
        )


def test_the_truths_are_those_of_the_scenes_the_study_runs():
    """One truth per scene of `run_wp` in its order; quick leaves out `QUICK_SKIP`."""
    quick = [s.name for s in report_scenes(True)]
    full = [s.name for s in report_scenes(False)]
    assert quick == [n for n in full if n not in QUICK_SKIP] and len(quick) < len(full), (
        f"got quick {quick}, full {full}, should be full without {QUICK_SKIP} "
        "[wp_summary.report_scenes]"
    )


def _draw(path: str, dies: bool = False) -> str:
    """A small figure into ``path``; its name (``dies``: the worker process exits first)."""
    from matplotlib.figure import Figure

    if dies and mp.parent_process() is not None:
        os._exit(3)
    fig = Figure(figsize=(2, 1.5), dpi=50)
    fig.subplots().loglog([1e-6, 1e-3, 1.0], [1.0, 1e-8, 1e-16], label="exact")
    fig.savefig(path)
    return os.path.basename(path)


def _fails(path: str) -> None:
    raise ValueError(f"no style for {path}")


FORKS = pytest.mark.skipif(
    "fork" not in mp.get_all_start_methods() or (os.cpu_count() or 1) < 2,
    reason="draws here where it cannot fork",
)


@FORKS
def test_a_figure_drawn_in_the_background_is_the_one_drawn_here(tmp_path):
    handle = _drawing.start(_draw, str(tmp_path / "there.png"))
    assert handle is not None, "got no background process, should fork one [_drawing.start]"
    got = _drawing.finish(handle, _draw, str(tmp_path / "there.png"))
    _draw(str(tmp_path / "here.png"))
    assert got == "there.png", f"got {got!r}, should be 'there.png' [_drawing.finish]"
    there, here = (tmp_path / "there.png").read_bytes(), (tmp_path / "here.png").read_bytes()
    assert there == here, (
        f"got {len(there)} bytes, should be the {len(here)} bytes drawn here [_drawing.finish]"
    )


@FORKS
def test_a_worker_that_dies_leaves_the_drawing_here(tmp_path):
    path = str(tmp_path / "fig.png")
    got = _drawing.finish(_drawing.start(_draw, path, True), _draw, path, True)
    assert got == "fig.png" and (tmp_path / "fig.png").is_file(), (
        f"got {got!r}, files {sorted(p.name for p in tmp_path.iterdir())}, should be "
        "'fig.png' drawn here [_drawing.finish after the worker exited]"
    )


def test_a_drawing_that_raises_raises_here(tmp_path):
    with pytest.raises(ValueError, match="no style"):
        _drawing.finish(_drawing.start(_fails, "x.png"), _fails, "x.png")
