"""The critical-step map of a report run: in background processes beside the claims, on a
local Dask cluster (``--workers N``), or here.

The map is the section 6 claim's measurement (`claims.sec6_dt_safe_bound.verdict_from_map`
is given the table); the searches are those of ``hcv sweep``'s engine.
"""

from __future__ import annotations

import multiprocessing as mp
import os
from concurrent.futures import ProcessPoolExecutor

import pandas as pd

from reference_impl.sweep import dt_crit_map_on_cluster
from reference_impl.sweep._map import map_case, map_frame, map_items

__all__ = ["MAP_WORKERS", "finish_map", "run_map", "start_map"]

# Processes of the background map: the claims and hard cases run here meanwhile (about a
# third of the map's CPU time), so on 2 cores a second map worker uses the core this
# process frees (quick report, machine at load 2-3: the wait for the map fell from 23 s
# to 16 s; the same table). The timed study starts only when all of them are done.
MAP_WORKERS = 2


def start_map(quick: bool):
    """Run the searches of the critical-step map in forked processes (>= 2 CPUs); None
    otherwise. Returns the pool and one future per search, in the map's order."""
    if (os.cpu_count() or 1) < 2 or "fork" not in mp.get_all_start_methods():
        return None
    try:
        pool = ProcessPoolExecutor(max_workers=MAP_WORKERS, mp_context=mp.get_context("fork"))
        return pool, [pool.submit(map_case, item) for item in map_items(quick=quick)]
    except (OSError, RuntimeError):
        return None


def finish_map(background, close: bool = True) -> pd.DataFrame:
    """The map's table from the background searches (`dt_crit_map_on_cluster`'s table).

    ``close=False`` leaves the pool running for the work queued behind the searches
    (`reference_impl.campaign._truths`); its owner shuts it down.
    """
    pool, futures = background
    try:
        frame = map_frame([f.result() for f in futures])
    except BaseException:
        # Ctrl-C, SIGTERM or a broken worker: the searches not yet started are dropped and
        # no running one is waited for (shutdown() would wait up to a search's length).
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    if close:
        pool.shutdown()
    return frame


def run_map(quick: bool, progress=None, workers: int = 0) -> pd.DataFrame:
    """The critical-step map through the sweep engine, with a textual progress callback.

    Parameters
    ----------
    quick : bool
        The smaller coverage of `reference_impl.studies.dtcrit_map.coverage`.
    progress : callable, optional
        Called with a short text after each search.
    workers : int
        0 runs the searches one after another in this process; N > 0 spreads them over
        a local Dask cluster of N processes (`reference_impl.sweep`). Same table either way.
    """

    def tick(done, total):
        if progress:
            progress(f"critical-step map: search {done}/{total}")

    return dt_crit_map_on_cluster(quick=quick, progress=tick, workers=workers)
