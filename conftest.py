"""Root pytest configuration: hypothesis profiles and the claim marker.

Select a profile with HYPOTHESIS_PROFILE=ci|dev|thorough (default: dev; CI sets ci).
"""

from __future__ import annotations

import os

from hypothesis import HealthCheck, settings

settings.register_profile(
    "ci",
    derandomize=True,
    database=None,
    max_examples=25,
    deadline=None,
    print_blob=True,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.register_profile(
    "dev", max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)
settings.register_profile(
    "thorough", max_examples=500, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "dev"))


def pytest_collection_modifyitems(config, items):
    """Reject a claim marker that names an unregistered claim, at collection time."""
    from verification.claims import claim_ids

    known = set(claim_ids())
    for item in items:
        for mark in item.iter_markers("claim"):
            if not mark.args or mark.args[0] not in known:
                raise ValueError(
                    f"{item.nodeid}: claim marker {mark.args!r} names no registered claim "
                    f"(see verification/claims.py)"
                )
