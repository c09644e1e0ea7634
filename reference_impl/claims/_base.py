"""The measurement every claim module returns, and helpers shared by the claim modules."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

__all__ = ["Measurement", "VERDICTS", "g"]

# Verdicts a claim can receive.
VERDICTS = ("verified", "refuted", "inconclusive")


@dataclass(frozen=True)
class Measurement:
    """The verdict of one claim with the numbers it was decided from.

    Attributes
    ----------
    claim : str
        The claim id.
    verdict : str
        One of `VERDICTS`.
    evidence : str
        One line written from the measured numbers (never typed).
    rule : str
        The rule that turned the numbers into the verdict, with its tolerances.
    figures : dict
        JSON-able measured figures and cases (written to results.json as ``measured``).
    counterexample : dict or None
        For a refuted claim: the case that breaks the statement as printed.
    headline : str
        A short line from the measured numbers (the README's verdict table).
    """

    claim: str
    verdict: str
    evidence: str
    rule: str
    figures: dict = field(default_factory=dict)
    counterexample: dict | None = None
    headline: str = ""

    def __post_init__(self):
        if self.verdict not in VERDICTS:
            raise ValueError(
                f"claim {self.claim}: verdict {self.verdict!r} is not one of {VERDICTS}"
            )
        if self.verdict == "refuted" and not self.counterexample:
            raise ValueError(f"claim {self.claim}: a refuted verdict needs a counterexample")

    def to_dict(self) -> dict:
        """JSON-ready dict: claim, verdict, evidence, rule, measured, counterexample."""
        from reference_impl.report._common import jsonable

        return {
            "claim": self.claim,
            "verdict": self.verdict,
            "evidence": self.evidence,
            "rule": self.rule,
            "measured": jsonable(self.figures),
            "counterexample": jsonable(self.counterexample),
            "headline": self.headline or self.evidence.split(";")[0],
        }


def g(x, digits: int = 3) -> str:
    """Short number: ``g(1.2345e-13) == '1.23e-13'``; NaN/None -> '–'."""
    if x is None:
        return "–"
    if isinstance(x, str):
        return x
    x = float(x)
    if math.isnan(x):
        return "–"
    if math.isinf(x):
        return "∞" if x > 0 else "−∞"
    if x == 0:
        return "0"
    if 1e-3 <= abs(x) < 1e5:
        return f"{x:.0f}" if abs(x) >= 10**digits else f"{x:.{digits}g}"
    mant, exp = f"{x:.{max(digits - 1, 0)}e}".split("e")
    if "." in mant:
        mant = mant.rstrip("0").rstrip(".")
    return f"{mant}e{int(exp)}"
