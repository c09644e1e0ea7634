"""Environment and provenance of a report run (taken before anything is written)."""

from __future__ import annotations

import os
from pathlib import Path

from reference_impl.provenance import machine_info

__all__ = [
    "PACKAGES",
    "compile_cache",
    "environment",
    "load_average",
    "load_note",
    "record_end",
]

PACKAGES = (
    "numpy",
    "scipy",
    "mpmath",
    "numba",
    "pandas",
    "matplotlib",
    "sympy",
    "hidden-harmonic-verification",
)


def load_average() -> list[float] | None:
    """The machine's load average over 1, 5 and 15 minutes (None where unknown): the
    timings a run measures are worth what the load beside them says (issue 41)."""
    try:
        return [round(x, 2) for x in os.getloadavg()]
    except OSError:
        return None


def compile_cache() -> dict:
    """numba's disk cache as a run starts: its directory and how many compiled functions
    it holds (``entries``, index files; 0: every kernel is compiled during the run, which
    costs minutes of the first run after an install)."""
    d = os.environ.get("NUMBA_CACHE_DIR")
    n = sum(1 for _ in Path(d).rglob("*.nbi")) if d and Path(d).is_dir() else 0
    return {"dir": d, "entries": n}


def load_note(load: list[float] | None, cores: int | None) -> str | None:
    """A warning line when the 1-minute load exceeds the cores (the timings are then
    slowed by other work), else None."""
    if load is None or not cores or load[0] <= cores:
        return None
    return (
        f"warning: load {load[0]:g} on {cores} cores: the timings this run measures are "
        "slowed by other work (the load is recorded beside them in results.json)"
    )


def environment(seeds: dict) -> dict:
    """Package versions, python, machine, git commit, hypothesis profile and seeds; the
    load and the compile cache as the run starts (``load_average_start``,
    ``compile_cache_start``)."""
    info = machine_info(PACKAGES)
    return {
        "python": info["python"],
        "implementation": info["implementation"],
        "platform": info["platform"],
        "machine": info["machine"],
        "processor": info["cpu"],
        "cpu_count": info["cpu_count"],
        "git_commit": info["commit"],
        "git_dirty": info["git_dirty"],
        "packages": info["packages"],
        "hypothesis_profile": os.environ.get("HYPOTHESIS_PROFILE"),
        "seeds": seeds,
        "load_average_start": load_average(),
        "compile_cache_start": compile_cache(),
    }


def record_end(env: dict, say) -> None:
    """Add the load as the run ends to ``env`` (``load_average_end``); ``say`` a warning
    line when it exceeds the cores (`load_note`)."""
    env["load_average_end"] = load_average()
    busy = load_note(env["load_average_end"], env.get("cpu_count"))
    if busy:
        say(busy)
