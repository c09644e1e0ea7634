"""What section 5's claim tests and tool tests share: the ODE tolerance and x(q) on a path.

`test_sec5_harmonic.py` (evidence for Theorem 2) and `test_tools_harmonic.py` (the
integrator checks) read them here.
"""

from __future__ import annotations

import numpy as np

from reference_impl import HarmonicMap
from reference_impl.claims._tolerances import ODE_RTOL

__all__ = ["_ODE_RTOL", "_x_on_path"]

# Shared with the claim modules (reason in reference_impl/claims/_tolerances.py).
_ODE_RTOL = ODE_RTOL


def _x_on_path(hmap: HarmonicMap, q: np.ndarray) -> np.ndarray:
    """x(q) on an ODE path (q >= 0; the clip only guards against round-off below 0)."""
    return hmap.x(np.maximum(q, 0.0))
