"""hcv run as a user runs it, in a new process, and the processes a test leaves behind.

Shared by the hostile-input tests of ``hcv bench`` (`verification/test_hostile_bench*.py`)
and the sweep's signal test (`verification/test_sweep_cluster.py`).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

__all__ = ["ROOT", "hcv", "processes_with"]

ROOT = Path(__file__).resolve().parent.parent


def hcv(args, cwd, timeout=120):
    """``hcv ARGS`` in a new process started in ``cwd`` (timeout in s); its CompletedProcess."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run(
        [sys.executable, "-m", "reference_impl.cli", *args],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def processes_with(needle: str) -> list[int]:
    """PIDs whose command line starts with ``needle`` (Linux /proc)."""
    pids = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                line = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode()
            except OSError:
                continue
            if line.startswith(needle):
                pids.append(int(entry.name))
    return pids
