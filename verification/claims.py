"""The claim registry used by the suite (defined in the package, shared with ``hcv report``)."""

from reference_impl.claims import CLAIMS, VERDICTS, Claim, claim_ids, get_claim

__all__ = ["CLAIMS", "VERDICTS", "Claim", "claim_ids", "get_claim"]
