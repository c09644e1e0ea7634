"""Independent check of the section 6 bound in assemblies (issue 39): Hertz chains and packings.

From the paper's equations only: Delta t_safe = 2 sqrt(m) / max U'/sqrt(2U) on [0, q_max]
(section 6) with U = k q^(p+1)/(p+1), U(q_max) = m v0^2 / 2 (the striker's mass and
energy). Velocity Verlet written here in numpy, vectorised over lanes: two steel spheres
(k = 1.0879e10 N/m^1.5, p = 3/2, m = 4.1103e-3 kg) touching each other and two walls, the
first struck at 1 m/s; 32 lanes whose initial speed differs in its last bits; a lane runs
away when E_n > 100 E_0 within 1000 steps and then exceeds 1e6 E_0 within 10000. Each
lane's smallest failing step is found by a scan in steps of 0.05 Delta t_safe and a
bisection; the 5 % point of the 32 values over Delta t_safe is compared by side of 1 with
the suite's (the suite's full report runs longer horizons, 1e4 and 1e5 steps, and reads
1e6 from the record reports/assemblies_1e6.json; the step only falls with the horizon).
The linear prediction sqrt(d / (2 Z)) is the textbook coordination of each lattice, and a
bonded linear chain between walls checks this loop against 2 / omega_max, omega_max =
2 sqrt(k/m) sin(N pi / (2N + 2)). Only numpy.
"""

import json
import math

import numpy as np

K, P, M, V0 = 1.0879e10, 1.5, 4.1103e-3, 1.0


def out(name, value, ours, tol, mode, why):
    print(
        "REPRO " + json.dumps(dict(name=name, value=value, ours=ours, tol=tol, mode=mode, why=why))
    )


def runs_away(force, n_bodies, dt, v_init, horizon, confirm):
    """Per lane: does velocity Verlet run away (E > 100 E0 in horizon, > 1e6 E0 in confirm)?"""
    lanes = dt.size
    x = np.zeros((lanes, n_bodies))
    v = np.zeros((lanes, n_bodies))
    v[:, 0] = v_init
    f, _ = force(x)
    e0 = 0.5 * M * v_init**2
    crossed = np.zeros(lanes, bool)
    failed = np.zeros(lanes, bool)
    h = dt[:, None]
    with np.errstate(all="ignore"):
        for n in range(1, confirm + 1):
            v += 0.5 * h * f / M
            x += h * v
            f, u = force(x)
            v += 0.5 * h * f / M
            e = 0.5 * M * np.sum(v * v, axis=1) + u
            crossed |= (n <= horizon) & (e > 100 * e0)
            failed |= crossed & ~(e <= 1e6 * e0)  # nan counts as failed
            if n == horizon and not crossed.any():
                break
            if np.all(failed | (~crossed & (n >= horizon))):
                break
    return failed


def hertz_pair(x):
    """Two spheres between two walls: overlaps -x0, x0 - x1, x1."""
    q = np.stack([-x[:, 0], x[:, 0] - x[:, 1], x[:, 1]], axis=1)
    qp = np.where(q > 0, q, 0.0)
    f = K * qp**P
    u = np.sum(K * qp ** (P + 1) / (P + 1), axis=1)
    return np.stack([f[:, 0] - f[:, 1], f[:, 1] - f[:, 2]], axis=1), u


q_max = (0.5 * M * V0**2 * (P + 1) / K) ** (1 / (P + 1))
dt_safe = 2 * math.sqrt(M) / (K * q_max**P / math.sqrt(2 * K * q_max ** (P + 1) / (P + 1)))
lanes = 32
v_init = V0 * (1 + np.arange(lanes) * 2.0**-52)
scan = np.arange(1, 41) * 0.05
first = np.full(lanes, np.inf)
for r in scan:  # the smallest failing scan step of each lane
    todo = np.isinf(first)
    if not todo.any():
        break
    f = runs_away(hertz_pair, 2, np.full(todo.sum(), r * dt_safe), v_init[todo], 1000, 10000)
    idx = np.flatnonzero(todo)[f]
    first[idx] = r
lo, hi = first - 0.05, first.copy()
for _ in range(5):  # bisect each lane's bracket
    mid = 0.5 * (lo + hi)
    f = runs_away(hertz_pair, 2, mid * dt_safe, v_init, 1000, 10000)
    hi = np.where(f, mid, hi)
    lo = np.where(f, lo, mid)
ratio_5 = float(np.quantile(hi, 0.05, method="lower"))
row = ["claims", {"id": "sec6-assemblies"}, "measured", "rows", {"case": "chain N=2, walls both"}]
out(
    "chain N=2: 5 % point of dt_crit / dt_safe",
    ratio_5,
    row + ["ratio_5"],
    1.0,
    "side",
    "below 1: the bound fails in the chain (horizons differ; the step falls with the horizon)",
)

# the linear prediction sqrt(d / (2 Z)) with textbook coordination numbers
for case, d, z in (
    ("chain N=2, walls both", 1, 2),
    ("square 4x4, periodic", 2, 4),
    ("triangular 4x4, periodic", 2, 6),
    ("honeycomb 4x4, periodic", 2, 3),
    ("fcc 1 cell, walled", 3, 12),
    ("bcc 1 cell, walled", 3, 8),
    ("simple-cubic 1 cell, walled", 3, 6),
):
    path = ["claims", {"id": "sec6-assemblies"}, "measured", "rows", {"case": case}]
    out(
        f"{case}: sqrt(d/2Z)",
        math.sqrt(d / (2 * z)),
        path + ["linear_prediction"],
        1e-12,
        "rel",
        "the linear lattice's 2/omega_max over the single contact's 2 sqrt(m/k)",
    )

# this loop on a bonded linear chain: its critical step is 2 / omega_max
k_lin, n_lin = 1e6, 5


def linear_chain(x):
    ext = np.concatenate([np.zeros((x.shape[0], 1)), x, np.zeros((x.shape[0], 1))], axis=1)
    q = ext[:, :-1] - ext[:, 1:]  # bonded: pulls as well as pushes
    f = k_lin * q
    return f[:, :-1] - f[:, 1:], np.sum(0.5 * k_lin * q * q, axis=1)


omega = 2 * math.sqrt(k_lin / M) * math.sin(n_lin * math.pi / (2 * n_lin + 2))
dts = 2 / omega * np.array([0.999, 1.001])
f = runs_away(linear_chain, n_lin, dts, np.full(2, 0.1), 20000, 200000)
out(
    "linear chain: stable at 0.999, runaway at 1.001 of 2/omega_max",
    float(abs(int(f[0]) - 0) + abs(int(f[1]) - 1)),
    None,
    0,
    "self",
    "the loop reproduces Verlet's linear stability boundary",
)
