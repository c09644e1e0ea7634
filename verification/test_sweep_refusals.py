"""``hcv sweep`` refuses what the single commands refuse, before any cluster (issue 29),
and a local cluster prints nothing about a busy dashboard port (issue 26, item 7).
"""

from __future__ import annotations

import socket
import warnings

from reference_impl.sweep._runner import run_cases
from verification._sweeps import needs_dask
from verification.assertions import assert_true

CLAIM = "sweep"  # the sweep machinery, not a paper claim


@needs_dask
def test_a_busy_port_8787_gives_no_warning():
    """Distributed starts an HTTP server even without a dashboard, on 8787 by default,
    and warned "Port 8787 is already in use" when another cluster held it."""
    holder = socket.socket()
    holder.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        try:
            holder.bind(("", 8787))
            holder.listen()
        except OSError:
            pass  # held by another process: busy either way
        with warnings.catch_warnings(record=True) as got:
            warnings.simplefilter("always")
            values = run_cases([1, -2], abs, workers=1)
    finally:
        holder.close()
    port = [str(w.message) for w in got if "already in use" in str(w.message)]
    assert_true(
        values == [1, 2] and not port,
        got=f"values {values}, warnings {port}",
        should="[1, 2] and no port warning",
        claim=CLAIM,
        call="run_cases(workers=1) with port 8787 busy",
    )
