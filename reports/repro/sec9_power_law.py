"""Independent check of section 9 (Eq. 12): for U = k q^(p+1)/(p+1) the universal law
C(q) = C0 sqrt(m/M) U'/sqrt(2 K U) (Eq. 11) is c q^((p-1)/2) (Tsuji's form).

The slope of ln(U'/sqrt(U)) against ln q over six decades, and max |C / (c q^((p-1)/2)) - 1|
with c = 2 zeta sqrt(m k (p+1)/2) (Eq. 11 with C0 = 2 zeta sqrt(K M), worked by hand),
k = 1e6, m = 0.05 kg, zeta = 0.3, (K, M) = (37, 0.02). Only numpy/scipy/mpmath.
"""

import json

import numpy as np

k, m, ZETA, K, M = 1e6, 0.05, 0.3, 37.0, 0.02


def out(name, value, ours, tol, mode, why):
    print(
        "REPRO " + json.dumps(dict(name=name, value=value, ours=ours, tol=tol, mode=mode, why=why))
    )


path = ["claims", {"id": "sec9-power-law"}, "measured", "rows"]
for p in (0.5, 1.0, 1.5, 2.0, 3.0, 5.0):
    q = np.logspace(-9, -3, 60)
    U, dU = k * q ** (p + 1) / (p + 1), k * q**p
    slope = float(np.polyfit(np.log(q), np.log(dU / np.sqrt(U)), 1)[0])
    out(
        f"slope of U'/sqrt(U), p = {p:g} ((p-1)/2 = {(p - 1) / 2:g})",
        slope,
        path + [{"p": p}, "slope"],
        1e-10,
        "abs",
        "least squares on an exact power: round-off ~1e-14",
    )
    C = 2 * ZETA * np.sqrt(K * M) * np.sqrt(m / M) * dU / np.sqrt(2 * K * U)
    c = 2 * ZETA * np.sqrt(m * k * (p + 1) / 2)
    out(
        f"max |C/(c q^((p-1)/2)) - 1|, p = {p:g}",
        float(np.max(np.abs(C / (c * q ** ((p - 1) / 2)) - 1))),
        path + [{"p": p}, "tsuji_rel_err"],
        1e-13,
        "below",
        "round-off of a dozen operations",
    )
