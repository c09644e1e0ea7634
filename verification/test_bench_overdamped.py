"""hcv bench on overdamped laws (issue 26 review, F2/F3): bounded exact references.

An overdamped law never brings the body back to q = 0 (e = 0 and contact time inf at the
overlap end). The bench's exact reference of a declared universal law must come from the
harmonic map for every zeta it covers (`solve_impact`, zeta up to ZETA_MAX), never from
the ODE (which creeps towards q = 0 for minutes); the DOP853 fallback of an opaque
C(q) has an evaluation budget and a one-line error.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

from reference_impl.adapters.base import ImplementedLaw
from reference_impl.bench.measure import exact_reference
from reference_impl.potentials.power import PowerLaw

from .assertions import assert_true

CLAIM = "bench-laws"  # the benchmark machinery, not a paper claim

_ROOT = Path(__file__).resolve().parents[1]
# Wall limit of the subprocess: import (~2 s) + two harmonic-map solves (~0.5 s each,
# the peak force by the general-law reference); on main the reference went to DOP853 and
# ran for minutes (F2). 60 s leaves a 20x margin on a loaded 2-core machine.
_LIMIT_S = 60

_PROBE = """
import json, math
from reference_impl.adapters.base import ImplementedLaw
from reference_impl.bench.measure import exact_reference
from reference_impl.potentials.power import PowerLaw
out = {}
for clip in (False, True):
    law = ImplementedLaw(PowerLaw(2.0e5, 1.0), 0.01, zeta=1.08, clips_tension=clip)
    ex = exact_reference(law, 0.5)
    out[str(clip)] = {k: ex[k] for k in ("method", "restitution", "contact_time",
                      "restitution_zero_force", "contact_time_zero_force")}
print(json.dumps(out))
"""


def test_the_reference_of_an_overdamped_universal_law_is_the_harmonic_map_in_bounded_time():
    env = {**os.environ, "PYTHONPATH": str(_ROOT)}
    try:
        done = subprocess.run(
            [sys.executable, "-W", "ignore", "-c", _PROBE],
            capture_output=True,
            text=True,
            timeout=_LIMIT_S,
            env=env,
            cwd=_ROOT,
        )
    except subprocess.TimeoutExpired:
        done = None
    got = json.loads(done.stdout) if done is not None and done.returncode == 0 else None
    free, clip = (got or {}).get("False", {}), (got or {}).get("True", {})
    ok = (
        got is not None
        and free["method"] == clip["method"] == "exact (harmonic map)"
        and free["restitution"] == 0.0
        and math.isinf(free["contact_time"])
        # tension clipped: the contact ends where the force vanishes, then free flight
        and clip["restitution"] == clip["restitution_zero_force"] > 0
        and clip["contact_time_zero_force"] < clip["contact_time"] < math.inf
    )
    assert_true(
        ok,
        got=(
            f"timed out after {_LIMIT_S} s"
            if done is None
            else (got or f"exit {done.returncode}: {done.stderr[-400:]}")
        ),
        should="the harmonic map's answer (e = 0, t_c = inf; clipped: e at zero force, "
        "finite t_c) within the time limit",
        claim=CLAIM,
        call="exact_reference(universal zeta = 1.08 on Hooke, v0 = 0.5 m/s) in a subprocess",
    )


def test_the_dop853_fallback_of_an_opaque_overdamped_law_stops_with_one_line():
    """A callable C(q) (no exact solver covers it) at damping ratio 1.3 on Hooke: the
    body creeps (~1.5e5 evaluations to the integrator's horizon, measured); the budget
    (50,000) stops it with one line naming the budget, in ~1 s."""
    m, k = 0.01, 2.0e5
    c = 2.0 * 1.3 * math.sqrt(m * k)
    law = ImplementedLaw(PowerLaw(k, 1.0), m, C=lambda q: c + 0.0 * q)
    try:
        exact_reference(law, 0.5)
        err = None
    except RuntimeError as exc:
        err = str(exc)
    assert_true(
        err is not None and "max_nfev" in err and "\n" not in err,
        got=repr(err),
        should="a one-line RuntimeError naming the evaluation budget (max_nfev)",
        claim=CLAIM,
        call="exact_reference(opaque C = 2 x 1.3 sqrt(m k) on Hooke, v0 = 0.5 m/s)",
    )
