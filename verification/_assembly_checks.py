"""What the assembly tests share: a linear search through a scene, and its settings.

They live in `reference_impl.campaign._assembly` (one home: the report's linear checks run
the same search with the same settings); its docstring says why 1e-6 relative is reachable
for bonded linear springs.
"""

from __future__ import annotations

from reference_impl.campaign._assembly import (
    LINEAR_CRITERION,
    LINEAR_GRID,
    LINEAR_RTOL,
    K,
    M,
    body_speeds,
    linear_search,
    scene_text,
)

__all__ = [
    "K", "LINEAR_CRITERION", "LINEAR_GRID", "LINEAR_RTOL", "M", "body_speeds", "linear_search",
    "scene_text",
]  # fmt: skip
