"""Cases shared by several claim modules (potential, mass, impact speed)."""

from __future__ import annotations

from reference_impl.potentials import PowerLaw
from reference_impl.studies.paper import PAPER_MASS, PAPER_V0_MIDDLE, paper_ellipsoid

# Hertz contact of the theory checks: k = 1e6, p = 1.5, on a 50 g body.
HERTZ = PowerLaw(1e6, 1.5)
MASS = 0.05
# (K, M) pairs spanning six decades each way, plus Fig. 1's (1, 0.75).
KM_PAIRS = ((1.0, 1.0), (1.0, 0.75), (1e-3, 1e3), (250.0, 4e-3), (37.0, 0.02))


def theory_cases():
    """(label, potential, mass kg, impact speed m/s): Hertz, the paper ellipsoid, a sum."""
    return [
        ("Hertz k=1e6 p=1.5", HERTZ, MASS, 1.0),
        ("paper ellipsoid", paper_ellipsoid(), PAPER_MASS, PAPER_V0_MIDDLE),
        ("sum q^2/2 + q^3/3 (k=1e4, 1e6)", PowerLaw(1e4, 1.0) + PowerLaw(1e6, 2.0), MASS, 1.0),
    ]
