"""Registry of the paper's claims: the single source the tests and the report use.

Each test in ``verification/`` carries ``@pytest.mark.claim("<id>")``;
``verification/test_meta.py`` fails when a claim has no test or a test names an
id that is not registered here. ``hcv report`` gives each claim a measured verdict.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Claim", "CLAIMS", "VERDICTS", "claim_ids", "get_claim"]

PAPER = "../shared/paper/hidden-harmonic-contact.tex"
# Verdicts a claim can receive in the report.
VERDICTS = ("verified", "refuted", "inconclusive")


@dataclass(frozen=True)
class Claim:
    """One checkable statement of the paper.

    Attributes
    ----------
    id : str
        Stable identifier, used by markers, the report and results.json.
    section : str
        Where the paper states it.
    statement : str
        The claim as the paper makes it (paraphrased only where LaTeX would not read).
    """

    id: str
    section: str
    statement: str


CLAIMS: tuple[Claim, ...] = (
    Claim(
        "thm1-period",
        "4 (Theorem 1)",
        "J(E) = sqrt(2m)/pi * int_0^qmax sqrt(E-U) dq is strictly increasing and the period of the "
        "contact oscillation, four times the quarter-period int_0^qmax dq/qdot, is T(E) = 2 pi dJ/dE.",
    ),
    Claim(
        "thm2-harmonic",
        "5 (Theorem 2)",
        "With x = sqrt(2U/K) and dtau/dt = sqrt(M/m) dx/dq every conservative trajectory satisfies "
        "M x'' + K x = 0 exactly, for any K, M > 0.",
    ),
    Claim(
        "km-cancellation",
        "5 (Remark), 6, 8",
        "The reference constants K and M cancel from every physical result: the damping law, the "
        "stability bound, the physical trajectory.",
    ),
    Claim(
        "thm3-damping-iff",
        "8 (Theorem 3)",
        "m q'' + C(q) q' + U'(q) = 0 maps to M x'' + C0 x' + K x = 0 with constant C0 if and only if "
        "C(q) = C0 sqrt(m/M) U'/sqrt(2 K U); restitution is then independent of impact speed.",
    ),
    Claim(
        "sec6-dt-safe-bound",
        "6",
        "Delta t_safe = 2 sqrt(m) / max_[0,qmax] U'/sqrt(2U) is a lower bound of the critical "
        "Verlet time step: every Delta t <= Delta t_safe is stable; for stiffening contacts "
        "(2UU'' >= U'^2, all power laws p >= 1) it equals 2 m v0 / U'(qmax).",
    ),
    Claim(
        "sec7-effective-mass",
        "7",
        "The point-canonical lift gives H = P^2/(2 M_eff(x)) + K x^2/2 with "
        "M_eff = 2 m K U / U'^2, constant if and only if U is proportional to q^2.",
    ),
    Claim(
        "sec9-power-law",
        "9",
        "For U = k q^(p+1)/(p+1) the universal law is C(q) proportional to q^((p-1)/2) "
        "(Tsuji damping, q^(1/4) for Hertz).",
    ),
    Claim(
        "sec10-stiffening-domain",
        "10",
        "The alpha = 0.5 ellipsoid model satisfies 2UU'' >= U'^2 for all delta <= 0.735 a.",
    ),
    Claim(
        "table1",
        "10 (Table 1)",
        "For the ellipsoid (a=0.015, b=c=0.008 m, m=0.05 kg, Kn=1e8, alpha=0.5) and v0 = 0.50, "
        "0.99, 1.50 m/s: delta_max, U'(delta_max) and Delta t_safe are as printed in Table 1.",
    ),
    Claim(
        "fig1",
        "10 (Fig. 1)",
        "For the Fig. 1 runs (K=1, M=0.75, C0 = 0 and 0.5) the Hamiltonian energy in the "
        "transformed space is conserved to a relative error < 3e-13; conservative orbits are "
        "semi-ellipses and dissipative ones logarithmic spirals in the (x, x') plane.",
    ),
)

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
