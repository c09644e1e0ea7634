"""The measurement every claim module returns, and helpers shared by the claim modules."""

from __future__ import annotations

from dataclasses import dataclass, field

from reference_impl._format import g, jsonable

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
        return {
            "claim": self.claim,
            "verdict": self.verdict,
            "evidence": self.evidence,
            "rule": self.rule,
            "measured": jsonable(self.figures),
            "counterexample": jsonable(self.counterexample),
            "headline": self.headline or self.evidence.split(";")[0],
        }
