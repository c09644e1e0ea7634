"""Hypothesis strategies for random monotone potentials and impact conditions.

Parameters are drawn on log scales over the ranges DEM users meet; ranges are
chosen so that every drawn case satisfies the paper's assumptions (the
bad-input tests build their violating cases explicitly).
"""

from __future__ import annotations

from hypothesis import strategies as st

from reference_impl.potentials import Ellipsoid, PowerLaw, Sphere, SumPotential

__all__ = [
    "log_uniform",
    "power_laws",
    "ellipsoids",
    "spheres",
    "sums",
    "monotone_potentials",
    "reference_constants",
    "masses",
    "speeds",
    "zetas",
]


def log_uniform(lo: float, hi: float) -> st.SearchStrategy[float]:
    """Floats spread evenly in log10 between lo and hi."""
    import math

    return st.floats(math.log10(lo), math.log10(hi)).map(lambda e: 10.0**e)


def power_laws(p_min: float = 0.5, p_max: float = 5.0) -> st.SearchStrategy[PowerLaw]:
    return st.builds(PowerLaw, k=log_uniform(1e2, 1e10), p=st.floats(p_min, p_max))


def ellipsoids() -> st.SearchStrategy[Ellipsoid]:
    return st.builds(
        Ellipsoid,
        a=log_uniform(1e-3, 1e-1),
        b=log_uniform(1e-3, 1e-1),
        c=log_uniform(1e-3, 1e-1),
        Kn=log_uniform(1e6, 1e12),
        alpha=st.floats(0.25, 1.5),
    )


def spheres() -> st.SearchStrategy[Sphere]:
    return st.builds(
        Sphere, R=log_uniform(1e-3, 1e-1), Kn=log_uniform(1e6, 1e12), alpha=st.floats(0.25, 1.5)
    )


def sums() -> st.SearchStrategy[SumPotential]:
    return st.lists(power_laws(0.8, 4.0), min_size=2, max_size=3).map(lambda ts: SumPotential(*ts))


def monotone_potentials() -> st.SearchStrategy:
    """Any family: power law, sum of power laws, ellipsoid, sphere."""
    return st.one_of(power_laws(), sums(), ellipsoids(), spheres())


def reference_constants() -> st.SearchStrategy[tuple[float, float]]:
    """Arbitrary virtual (K, M) over six decades each."""
    return st.tuples(log_uniform(1e-3, 1e3), log_uniform(1e-3, 1e3))


def masses() -> st.SearchStrategy[float]:
    return log_uniform(1e-4, 1e1)


def speeds() -> st.SearchStrategy[float]:
    return log_uniform(1e-2, 1e1)


def zetas() -> st.SearchStrategy[float]:
    return st.floats(0.0, 0.9)


# -- impacts (appended for the section 5/8 ODE tests) -----------------------------

# Largest drawn turning point on a finite-domain potential, as a fraction of q_sup
# (= 2a for the caps): 0.35 q_sup = 0.7 a keeps every impact inside the elastic
# domain delta <= 0.735 a that section 10 calls physically valid.
_CAP_QMAX_FRACTION_MAX = 0.35
# Smallest drawn fraction: three decades below the largest.
_CAP_QMAX_FRACTION_MIN = 3.5e-4


@st.composite
def impacts(draw, potentials=None):
    """Impact cases ``(potential, m, v0)`` whose turning point exists.

    Power laws and sums take ``v0`` from `speeds`; potentials with a finite
    domain (the caps) draw the turning point q_max as a fraction of ``q_sup`` and
    derive ``v0 = sqrt(2 U(q_max) / m)``, so that no case leaves the domain.

    Parameters
    ----------
    potentials : SearchStrategy, optional
        Strategy for the potential; default `monotone_potentials`.
    """
    import math

    pot = draw(potentials if potentials is not None else monotone_potentials())
    m = draw(masses())
    if math.isfinite(pot.q_sup):
        frac = draw(log_uniform(_CAP_QMAX_FRACTION_MIN, _CAP_QMAX_FRACTION_MAX))
        v0 = math.sqrt(2.0 * float(pot.U(frac * pot.q_sup)) / m)
    else:
        v0 = draw(speeds())
    return pot, m, v0


__all__ += ["impacts"]


# -- exact solver over its whole accepted range (appended for test_exact_*) ---------


def exact_zetas() -> st.SearchStrategy[float]:
    """Damping ratios over [0, 10] with extra weight near critical damping.

    Draws avoid the band just below 1 that `solve_impact` refuses (the theory's
    end of contact beyond virtual time S_END_MAX, i.e. outside float64 range).
    """
    import math

    from reference_impl._oscillator import S_END_MAX

    # Just inside the accepted band (the limit itself rounds either way).
    z_lim = math.sqrt(1.0 - (math.pi / S_END_MAX) ** 2) - 1e-7
    return st.one_of(
        st.floats(0.0, 10.0),
        st.floats(0.99, z_lim),
        st.floats(1.0, 1.001),
        st.floats(1e-12, 1e-3),
    ).filter(lambda z: not z_lim < z < 1.0)


__all__ += ["exact_zetas"]
