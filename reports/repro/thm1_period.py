"""Independent check of Theorem 1 (section 4, Eqs. 2-3): T(E) = 2 pi dJ/dE.

J(E) = sqrt(2m)/pi int_0^qmax sqrt(E-U) dq (Eq. 2); the period T is four times the
quarter period int_0^qmax dq/qdot with qdot = sqrt(2(E-U)/m) (proof of Theorem 1).
dJ/dE by a central difference of J. Cases as in reference_impl/claims/thm1_period.py.
Only numpy/scipy/mpmath. Prints one JSON line per decisive number (REPRO {...}).
"""

import json

import mpmath as mp

DPS = 70  # working digits: quadrature and the difference quotient both far below 1e-30
H_REL = mp.mpf(10) ** -20  # difference step / E: truncation ~1e-40, cancellation ~1e-50


def out(name, value, ours, tol, mode, why):
    print(
        "REPRO " + json.dumps(dict(name=name, value=value, ours=ours, tol=tol, mode=mode, why=why))
    )


def power(k, p):
    return lambda q: k * q ** (p + 1) / (p + 1)


def ellipsoid(a, b, c, Kn, alpha):  # Eqs. 13-14
    return lambda d: (
        Kn / (alpha + 1) * (mp.pi * b * c / a**2 * (a * d**2 - d**3 / 3)) ** (alpha + 1)
    )


mp.mp.dps = DPS  # the decimal inputs below are exact to DPS digits
CASES = {  # name -> (U, m kg, E J)
    "Hertz": (power(mp.mpf(10) ** 6, mp.mpf(1.5)), mp.mpf("0.05"), mp.mpf("0.0123")),
    "paper ellipsoid": (
        ellipsoid(
            mp.mpf("0.015"), mp.mpf("0.008"), mp.mpf("0.008"), mp.mpf(10) ** 8, mp.mpf("0.5")
        ),
        mp.mpf("0.05"),
        mp.mpf("0.05") * mp.mpf("0.99") ** 2 / 2,
    ),
    "sum linear + q^3.5": (
        lambda q: power(mp.mpf(10) ** 5, 1)(q) + power(mp.mpf(10) ** 8, mp.mpf(2.5))(q),
        mp.mpf("0.02"),
        mp.mpf("0.03"),
    ),
}


def qmax(U, E):
    hi = mp.mpf(1e-6)
    while U(hi) < E:
        hi *= 2
    return mp.findroot(lambda q: U(q) - E, (hi / 2, hi), solver="anderson")


def J(U, m, E):
    return mp.sqrt(2 * m) / mp.pi * mp.quad(lambda q: mp.sqrt(max(E - U(q), 0)), [0, qmax(U, E)])


def quarter(U, m, E):
    qm = qmax(U, E)
    # q = qm (1 - s^2) removes the 1/sqrt singularity at the turning point.
    return mp.quad(
        lambda s: 2 * s * qm / mp.sqrt(2 * max(E - U(qm * (1 - s * s)), mp.eps) / m), [0, 1]
    )


with mp.workdps(DPS):
    for name, (U, m, E) in CASES.items():
        h = E * H_REL
        dJ = (J(U, m, E + h) - J(U, m, E - h)) / (2 * h)
        T = 4 * quarter(U, m, E)
        path = ["claims", {"id": "thm1-period"}, "measured", name]
        out(
            f"T/(2 pi dJ/dE), {name}",
            mp.nstr(T / (2 * mp.pi * dJ), 35),
            path + ["T_over_2pi_dJdE"],
            1e-28,
            "abs",
            "central difference of J at 70 digits: error ~1e-36; ours is 40-digit",
        )
        out(
            f"T [s], {name}",
            mp.nstr(T, 30),
            path + ["T_s"],
            1e-15,
            "rel",
            "ours takes 0.05, 0.0123, 0.015, 0.99 as float64 and forms b*c in float64: ~1e-16 relative",
        )
        out(
            f"|t_c/(2 pi dJ/dE) - 1|, t_c = T/2, {name}",
            float(abs(T / 2 / (2 * mp.pi * dJ) - 1)),
            path + ["abs_tc_over_2pi_dJdE_minus_1"],
            1e-28,
            "below",
            "both zero to the working precision",
        )
    # Closed form for the power law (Hertz): t_c = 2 (qm/v0) sqrt(pi) Gamma(1+1/n)/Gamma(1/2+1/n), n = p+1.
    U, m, E = CASES["Hertz"]
    n, v0 = mp.mpf(2.5), mp.sqrt(2 * E / m)
    tc = 2 * qmax(U, E) / v0 * mp.sqrt(mp.pi) * mp.gamma(1 + 1 / n) / mp.gamma(mp.mpf(0.5) + 1 / n)
    out(
        "closed-form 2 t_c [s], Hertz",
        mp.nstr(2 * tc, 30),
        ["claims", {"id": "thm1-period"}, "measured", "Hertz", "T_s"],
        1e-15,
        "rel",
        "Beta-function contact time of a power law; ours from float64 inputs",
    )
