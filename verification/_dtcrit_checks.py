"""What section 6's claim tests and tool tests share: the search resolution and a Hertz law.

`test_sec6_dtcrit.py` (evidence for the section 6 bound) and `test_tools_dtcrit.py`
(the search machinery on known truths) read them here.
"""

from __future__ import annotations

from reference_impl.potentials import PowerLaw
from reference_impl.stability.search import SearchGrid

__all__ = ["HERTZ", "RES", "TWO_BRACKETS"]

# The resolution of every search: brackets narrower than 0.1 % of dt_safe.
RES = SearchGrid().resolution
# Two searches of the same threshold may land anywhere in their brackets, so
# they agree to two bracket widths.
TWO_BRACKETS = 2 * RES
HERTZ = PowerLaw(1.0, 1.5)
