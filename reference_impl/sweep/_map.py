"""The report's critical-step map through the sweep engine (local processes or a cluster).

`dt_crit_map_on_cluster` returns the same table as
`reference_impl.studies.dtcrit_map.dt_crit_map` (same rows, same order, same columns:
each (case, scene kind) search is one sweep case built by the map module's own
row function), with the searches spread over worker processes by `run_cases`.
Without Dask, or with ``workers=0``, it runs them serially in this process.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import pandas as pd

from reference_impl.stability.search import KINDS, SearchGrid, default_criterion
from reference_impl.studies.dtcrit_map import coverage, map_case_rows
from reference_impl.sweep._runner import run_cases

__all__ = ["dt_crit_map_on_cluster", "map_case", "map_frame", "map_items"]

# The map module's default search settings (a frozen dataclass, safe to share).
_DEFAULT_GRID = SearchGrid()


def map_case(item) -> list[dict]:
    """One (case, kind) search of the map: its rows, as `dt_crit_map` builds them."""

    case, kind, criterion, grid = item
    return map_case_rows(case, kind, criterion, grid)


def dt_crit_map_on_cluster(
    cases: Sequence | None = None,
    kinds: Sequence[str] = KINDS,
    *,
    quick: bool = False,
    criteria: dict | None = None,
    grid: SearchGrid = _DEFAULT_GRID,
    progress: Callable[[int, int], None] | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
) -> pd.DataFrame:
    """`dt_crit_map` with one sweep case per (case, scene kind), run by `run_cases`.

    Parameters
    ----------
    cases, kinds, quick, criteria, grid, progress
        As `reference_impl.studies.dtcrit_map.dt_crit_map` (progress: ``(done, total)``
        after each finished search, in completion order).
    workers : int, optional
        Local worker processes (default: the CPU count); 0 runs serially here.
    scheduler : str, optional
        Address of an existing Dask scheduler.

    Returns
    -------
    pandas.DataFrame
        The rows of `dt_crit_map`, in its order.
    """
    items = map_items(cases, kinds, quick=quick, criteria=criteria, grid=grid)
    parts = run_cases(items, map_case, workers=workers, scheduler=scheduler, progress=progress)
    return map_frame(parts)


def map_items(
    cases: Sequence | None = None,
    kinds: Sequence[str] = KINDS,
    *,
    quick: bool = False,
    criteria: dict | None = None,
    grid: SearchGrid = _DEFAULT_GRID,
) -> list[tuple]:
    """The map's searches, one item per (case, scene kind), in the map's order: each is
    what `map_case` runs (arguments as `dt_crit_map_on_cluster`)."""

    cases = coverage(quick) if cases is None else list(cases)
    criteria = criteria or {}
    return [
        (case, kind, criteria.get(kind, default_criterion(kind)), grid)
        for case in cases
        for kind in kinds
    ]


def map_frame(parts: Sequence[list[dict]]) -> pd.DataFrame:
    """The map's table from the rows of its searches, given in `map_items` order."""
    return pd.DataFrame([row for part in parts for row in part])
