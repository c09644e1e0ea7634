"""Independent check of Fig. 1 (section 10): "the Hamiltonian energy in this transformed space
is conserved to machine precision (relative error < 3e-13)" with ode45 at RelTol = AbsTol = 1e-13.

The paper ellipsoid (Eqs. 13-14), K = 1, M = 0.75, C0 = 0 and 0.5 (Eq. 11), v0 = 0.50, 0.99,
1.50 m/s. scipy's RK45 (the Dormand-Prince 5(4) pair of ode45) on (q, q') in SI units at
rtol = atol = 1e-13, from q = 0 to the return to q = 0. H = M x'^2/2 + K x^2/2 with x =
sqrt(2U/K) (Eq. 4) and x' = q' sqrt(m/M) (proof of Theorem 2), at the solver's steps.
Only numpy/scipy/mpmath.
"""

import json

import numpy as np
from scipy.integrate import solve_ivp

a, bc, Kn, m, K, M = 0.015, 0.008 * 0.008, 1e8, 0.05, 1.0, 0.75
g0 = np.pi * bc / a**2
V = lambda d: g0 * (a * d**2 - d**3 / 3)  # noqa: E731
U = lambda d: Kn / 1.5 * V(d) ** 1.5  # noqa: E731
dU = lambda d: Kn * np.sqrt(V(d)) * g0 * (2 * a * d - d**2)  # noqa: E731


def out(name, value, ours, tol, mode, why):
    print(
        "REPRO " + json.dumps(dict(name=name, value=value, ours=ours, tol=tol, mode=mode, why=why))
    )


def run(v0, C0):
    C = lambda q: C0 * np.sqrt(m / M) * dU(q) / np.sqrt(2 * K * U(q)) if q > 0 else 0.0  # noqa: E731  Eq. 11
    # SI units, as the paper states the tolerances. With states scaled to the motion (as
    # reference_impl integrates) the same RK45 drifts 1.9e-13, 5.5e-12, 5.7e-12 here: the
    # drift is a property of the integrator run, not of Theorem 2.
    rhs = lambda t, y: [y[1], (-dU(max(y[0], 0.0)) - C(max(y[0], 0.0)) * y[1]) / m]  # noqa: E731
    ev = lambda t, y: y[0] if t > 0 else 1.0  # noqa: E731
    ev.terminal, ev.direction = True, -1
    r = solve_ivp(rhs, (0, 1.0), [0.0, v0], method="RK45", rtol=1e-13, atol=1e-13, events=ev)
    q, v = np.maximum(r.y[0], 0.0), r.y[1]
    H = 0.5 * M * (v * np.sqrt(m / M)) ** 2 + 0.5 * K * (2 * U(q) / K)
    E = 0.5 * m * v**2 + U(q)
    return (
        float(np.max(np.abs(H / H[0] - 1))),
        float(H[-1] / H[0]),
        float(np.max(np.abs(H / E - 1))),
    )


CLAIMED = 3e-13  # the printed bound on the relative drift (Fig. 1 text)
path = ["claims", {"id": "fig1"}, "measured", "runs"]
drifts = []
for C0 in (0.0, 0.5):
    zeta = C0 / (2 * np.sqrt(K * M))
    e = np.exp(-np.pi * zeta / np.sqrt(1 - zeta**2))
    for v0 in (0.5, 0.99, 1.5):
        drift, end, ident = run(v0, C0)
        sel = path + [{"v0": v0, "C0": C0}]
        if C0 == 0:
            drifts.append(drift)
            out(
                f"C0 = 0, v0 = {v0}: max |H/H0 - 1| (RK45, 1e-13)",
                drift,
                sel + ["drift"],
                0.5,
                "rel",
                "the same method and tolerances; a factor 1.5 allows for a different step history",
            )
        else:
            out(
                f"C0 = 0.5, v0 = {v0}: H_end/H0 (= e^2 = {e * e:.10f})",
                end,
                sel + ["H_end_over_H0"],
                1e-9,
                "abs",
                "RK45 at 1e-13: e to ~1e-11",
            )
        out(
            f"C0 = {C0}, v0 = {v0}: max |H/E_phys - 1|",
            ident,
            sel + ["identity_err"],
            1e-13,
            "below",
            "H = M x'^2/2 + K x^2/2 is m q'^2/2 + U identically: round-off",
        )
# What the verdict rests on: a C0 = 0 run drifting >= the printed bound refutes the claim,
# so the largest of the three drifts must lie on the same side of 3e-13 in both codes
# (the drifts themselves depend on the state scaling: see known_differences.json).
out(
    "the printed bound on the relative drift",
    CLAIMED,
    path[:-1] + ["claimed"],
    None,
    "equal",
    "the threshold both verdicts use",
)
out(
    f"C0 = 0: largest max |H/H0 - 1| of the three runs, against the printed {CLAIMED:g}",
    max(drifts),
    path + [{"$max": "drift", "where": {"C0": 0.0}}],
    CLAIMED,
    "side",
    "the claim is refuted iff a C0 = 0 run drifts >= the printed bound: both on the same side of it",
)
