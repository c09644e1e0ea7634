"""Machine and commit information printed with every benchmark result."""

from __future__ import annotations

import os
import platform
import subprocess
import sys
from importlib import metadata


def machine_info() -> dict:
    """Python, platform, CPU count, key package versions and the git commit."""
    try:
        commit = (
            subprocess.run(
                ["git", "rev-parse", "HEAD"],
                capture_output=True,
                text=True,
                check=False,
                cwd=os.path.dirname(__file__),
            ).stdout.strip()
            or None
        )
    except OSError:
        commit = None
    versions = {}
    for pkg in ("numpy", "scipy", "mpmath", "numba", "pandas"):
        try:
            versions[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            versions[pkg] = None
    return {
        "python": sys.version.split()[0],
        "platform": platform.platform(),
        "machine": platform.machine(),
        "processor": platform.processor() or None,
        "cpu_count": os.cpu_count(),
        "commit": commit,
        "packages": versions,
    }
