"""A figure of the report drawn in a forked process while this one runs the next stages.

Drawing is the report's largest serial work after its timed study (the speed-against-error
figures: ~4 s of CPU in a quick report, measured 2026-11-29); the stages after that study
(the damping laws, the assemblies) need another ~2 s and none of its figures. `start`
forks one process that draws while they run; `finish` returns what the drawing function
returned. The figure files are those the function writes here: the same function, the same
data (a forked copy), the same bytes.
"""

from __future__ import annotations

import multiprocessing as mp
import os
from concurrent.futures import ProcessPoolExecutor

__all__ = ["cancel", "finish", "start"]


def start(fn, *args):
    """``fn(*args)`` in a forked process; a handle for `finish`, or None where the machine
    has one CPU or cannot fork (`finish` then draws here)."""
    if (os.cpu_count() or 1) < 2 or "fork" not in mp.get_all_start_methods():
        return None
    try:
        pool = ProcessPoolExecutor(max_workers=1, mp_context=mp.get_context("fork"))
        return pool, pool.submit(fn, *args)
    except (OSError, RuntimeError):
        return None


def finish(handle, fn, *args):
    """What ``fn(*args)`` returned in the process `start` forked (None: call it here).

    A broken worker draws here instead; Ctrl-C or SIGTERM drops the worker unwaited.
    """
    if handle is None:
        return fn(*args)
    pool, future = handle
    try:
        out = future.result()
    except BaseException as exc:
        pool.shutdown(wait=False, cancel_futures=True)
        if not isinstance(exc, Exception):
            raise
        return fn(*args)
    pool.shutdown()
    return out


def cancel(handle) -> None:
    """Drop the drawing (an error in the stages between `start` and `finish`)."""
    if handle is not None:
        handle[0].shutdown(wait=False, cancel_futures=True)
