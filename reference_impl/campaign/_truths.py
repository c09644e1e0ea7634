"""The work-precision study's 30-digit truths, computed in the report's background processes.

The truths (`reference_impl.studies.workprecision.ground_truth`) are pure computation:
~3/4 of the study's CPU time in a quick report, none of it timed. `hcv report` runs the
timed study alone after the critical-step map, on one core; computed there, the truths
left the second core idle. Queued behind the map's searches in its background processes,
they run beside the claims instead, and are handed to the study (`remember_truth`) before
its first timing: the study's rows are the same (a truth is a deterministic function of
its scene), and no timing shares the machine with them.
"""

from __future__ import annotations

from concurrent.futures import Future

from reference_impl.studies.workprecision import ground_truth, remember_truth
from reference_impl.studies.wp_summary import report_scenes

__all__ = ["collect_truths", "submit_truths"]


def _truth(quick: bool, index: int):
    """The truth of the study's scene ``index`` (run in a worker: the scene is rebuilt
    there, as a user expression's compiled form need not cross a process boundary)."""
    return ground_truth(report_scenes(quick)[index])


def submit_truths(pool, quick: bool) -> list[Future]:
    """Queue the truths of `report_scenes(quick)` on ``pool`` (the map's, `_map.start_map`),
    behind the searches already queued there; one future per scene, in the study's order."""
    return [pool.submit(_truth, quick, i) for i in range(len(report_scenes(quick)))]


def collect_truths(futures: list[Future], quick: bool) -> None:
    """Wait for the truths and keep them in this process for `run_wp` (`remember_truth`).

    Raises what a worker raised; the caller then lets the study compute them itself.
    """
    for sc, fut in zip(report_scenes(quick), futures, strict=True):
        remember_truth(sc, fut.result())
