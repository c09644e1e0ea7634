"""Environment and provenance of a report run (taken before anything is written)."""

from __future__ import annotations

import os

from reference_impl.provenance import machine_info

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


def environment(seeds: dict) -> dict:
    """Package versions, python, machine, git commit, hypothesis profile and seeds."""
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
    }
