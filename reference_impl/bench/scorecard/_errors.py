"""How the run of one variant on one scene stops early: the code declined the scene
(`_Declined`, a skip), our own reference failed (`_Ours`, an internal error), or the code
declared a law no reference can be computed for (`DeclaredLawError`, exit status 2).

`DeclaredLawError` is importable from `reference_impl.bench.scorecard.runner` as well.
"""

from __future__ import annotations

from reference_impl.errors import HCVInputError

__all__ = ["DeclaredLawError"]


class _Declined(Exception):
    """The code declined the scene at run time ({"unsupported": reason}): a skip."""


class _Ours(Exception):
    """The suite's own reference failed: an internal error, never the code's failure."""


class DeclaredLawError(HCVInputError):
    """A code declared an implemented law no reference can be computed for (its
    configuration error): ``hcv bench`` stops with exit status 2, naming the field."""
