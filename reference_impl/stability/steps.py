"""The bracket search of `search_scene` on lanes that are not one particle's.

`search_steps` runs the same rounds as `reference_impl.stability.search.search_scene`
(grid scan, extension up or down, k-section of the smallest failure: `_next_dts` on each
search's `_Search` bracket), around an evaluator the caller supplies, so that the
assembly searches (`reference_impl.assembly.search`) reuse the suite's search instead of
a second copy of it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from reference_impl.stability.criteria import SearchGrid
from reference_impl.stability.search import _next_dts, _progress_fraction, _Search

__all__ = ["search_steps"]

# The default scan and refinement of `search_scene`.
_DEFAULT_GRID = SearchGrid()


def search_steps(
    evaluate: Callable[[dict], dict],
    dt_refs: Sequence[float],
    grid: SearchGrid = _DEFAULT_GRID,
    progress: Callable[[float, float], None] | None = None,
) -> list[_Search]:
    """The bracket searches of `search_scene` (scan, extension, k-section) on any lanes.

    The same rounds as `search_scene`'s, for a caller whose lanes are not one
    particle's: the assembly searches run them on chains and lattices.

    Parameters
    ----------
    evaluate : callable
        ``evaluate({i: dts}) -> {i: [(dt, failed, evidence, bounded_peak), ...]}``: runs
        the steps ``dts`` (s) each search ``i`` needs next and says for each whether it
        failed (a runaway), its evidence (``"confirmed"`` or ``"domain"``, None when it did
        not fail) and the peak E / E_0 of a bounded excursion (None when there was none);
        a step left out of the answer counts as not run.
    dt_refs : sequence of float
        Reference step of each search (s): the scan is in its units (Delta t_safe, or
        another step where Delta t_safe is 0).
    grid : SearchGrid
        Scan and refinement (resolution in units of each reference step).
    progress : callable, optional
        ``progress(completed, total)`` after each round, as for `search_scene`.

    Returns
    -------
    list
        One finished search per reference step: ``bracket()`` gives (largest stable step
        below the smallest failure, smallest failing step) in s (inf: none failed),
        ``smallest_bounded()`` the smallest bounded step below it and its peak,
        ``evidence`` each failing step's evidence.
    """
    searches = [_Search(math.nan, float(r), np.zeros(1)) for r in dt_refs]
    if progress is not None:
        progress(0.0, float(len(searches)))
    for _ in range(200):  # rounds; a search needs ~4, the cap only guards against a bug
        need = {}
        for i, s in enumerate(searches):
            if s.done:
                continue
            d = _next_dts(s, grid)
            if d.size:
                need[i] = d
            else:
                s.done = True
        if not need:
            break
        for i, rows in evaluate(need).items():
            s = searches[i]
            for dt, failed, evidence, peak in rows:
                key = float(dt)
                if failed:
                    s.tried[key] = True
                    s.evidence[key] = evidence
                else:
                    s.tried.setdefault(key, False)
                    if peak is not None:
                        s.bounded[key] = float(peak)
        if progress is not None:
            progress(sum(_progress_fraction(s, grid) for s in searches), float(len(searches)))
    if progress is not None:
        progress(float(len(searches)), float(len(searches)))
    return searches
