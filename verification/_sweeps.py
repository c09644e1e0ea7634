"""What the ``hcv sweep`` tests share: a cheap spec, ``hcv`` run in this process, and
the mark of the tests that need ``dask.distributed``.

Used by `verification/test_sweep.py`, `test_sweep_cluster.py` and `test_sweep_bench.py`.
"""

from __future__ import annotations

import textwrap

import pytest

from reference_impl.cli import main as hcv_main
from reference_impl.sweep._runner import dask_available

__all__ = ["SPEC", "cli", "needs_dask"]


needs_dask = pytest.mark.skipif(
    not dask_available(), reason="dask.distributed not installed (pip install -e '.[sweep]')"
)


# Single impacts with a loose criterion: about 10 ms a case, so the cluster
# tests measure the sweep machinery, not the search.
SPEC = textwrap.dedent(
    """
    task = "dt-crit"
    criterion = "tol=0.5,n_phases=2"
    [scene]
    name = "impact-map"
    mass = 1.0
    velocities = [1.0]
    kind = "impact"
    [scene.potential]
    family = "power"
    k = 1.0
    p = 1.5
    [sweep]
    "potential.p" = [1.0, 1.5, -1.0, 3.0]
    "mass" = [1.0, 2.0]
    """
)


def cli(args, capsys):
    """``hcv ARGS`` in this process: (exit status, stdout, stderr), read through ``capsys``."""
    code = hcv_main(args)
    out = capsys.readouterr()
    return code, out.out, out.err
