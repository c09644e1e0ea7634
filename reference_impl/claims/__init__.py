"""Registry of the paper's claims: one module per claim, the single source of every verdict.

Each claim module (``reference_impl/claims/<name>.py``) holds the claim's ``ID``,
``SECTION``, ``STATEMENT``, its cases, its tolerances (named constants, each
with the reason for its size) and ``measure(quick=False) -> Measurement``, cached
per process. ``hcv report`` loops over `CLAIMS` and writes each measurement;
the tests in ``verification/test_sec*.py`` carry ``pytest.mark.claim(ID)`` and
assert on the same measurement (or its case functions).

A claim that does not hold as printed also holds its own erratum text: ``PRINTED``
(where the paper states it, the equation number or None, the LaTeX as printed; checked
verbatim against the .tex) and ``corrected(measured, results) -> (corrected, numbers)``
(the corrected statement and the decisive numbers, read from the results dict); the
report's erratum (`reference_impl.report._erratum`) only formats them.

Adding a claim: write ``reference_impl/claims/<name>.py`` with the names above,
add ``<name>`` to `_MODULES` below, write a test marked
``@pytest.mark.claim("<id>")`` that calls ``<name>.measure()``, and its independent
script ``reports/repro/<name>.py``.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from types import ModuleType

from reference_impl.claims._base import VERDICTS, Measurement

__all__ = ["Claim", "CLAIMS", "VERDICTS", "Measurement", "claim_ids", "get_claim", "measure"]

# Claim modules in paper order.
_MODULES = (
    "thm1_period",
    "thm2_harmonic",
    "km_cancellation",
    "thm3_damping_iff",
    "sec6_dt_safe_bound",
    "sec6_assemblies",
    "sec7_effective_mass",
    "sec9_power_law",
    "sec10_stiffening_domain",
    "table1",
    "fig1",
)


@dataclass(frozen=True)
class Claim:
    """One checkable statement of the paper.

    Attributes
    ----------
    id : str
        Stable identifier, used by marks, the report and results.json.
    section : str
        Where the paper states it.
    statement : str
        The claim as the paper makes it (paraphrased only where LaTeX would not read).
    module : str
        Name of the claim module in `reference_impl.claims` that measures it.
    """

    id: str
    section: str
    statement: str
    module: str = ""

    @property
    def home(self) -> ModuleType:
        """The claim module (ID, SECTION, STATEMENT, tolerances, measure)."""
        return importlib.import_module(f"{__name__}.{self.module}")

    def measure(self, quick: bool = False) -> Measurement:
        """The claim's measurement (cached per process by the module)."""
        return self.home.measure(quick)

    @property
    def printed(self) -> tuple[str, int | None, str] | None:
        """(where, equation number or None, LaTeX as printed), or None where not quoted."""
        return getattr(self.home, "PRINTED", None)

    def corrected(self, measured: dict, results: dict) -> tuple[str, str] | None:
        """The corrected statement and the decisive numbers, from a results.json claim
        entry, by the claim module's ``corrected(m, r)`` (present where the claim does not
        hold as printed), or None.

        Parameters
        ----------
        measured : dict
            The claim's ``measured`` figures as written to results.json (the module's
            ``m``).
        results : dict
            The whole results dict (the module's ``r``; the erratum of section 6 reads
            the critical-step map).

        Returns
        -------
        (str, str) or None
            The corrected statement and the numbers it rests on (read, never typed).
        """
        fn = getattr(self.home, "corrected", None)
        return None if fn is None else fn(measured, results)


def _load(name: str) -> Claim:
    mod = importlib.import_module(f"{__name__}.{name}")
    return Claim(mod.ID, mod.SECTION, mod.STATEMENT, name)


CLAIMS: tuple[Claim, ...] = tuple(_load(n) for n in _MODULES)

_BY_ID = {c.id: c for c in CLAIMS}


def claim_ids() -> tuple[str, ...]:
    """All registered claim ids, in paper order."""
    return tuple(c.id for c in CLAIMS)


def get_claim(claim_id: str) -> Claim:
    """The claim with this id; KeyError naming the id otherwise."""
    try:
        return _BY_ID[claim_id]
    except KeyError:
        raise KeyError(f"unknown claim id {claim_id!r}; registered: {', '.join(_BY_ID)}") from None


def measure(claim_id: str, quick: bool = False) -> Measurement:
    """The measurement of one claim by id."""
    return get_claim(claim_id).measure(quick)
