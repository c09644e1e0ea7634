"""The report's assemblies stage (issue 39 section 6): the linear closed forms through the search.

The nonlinear table and the P_fail curves are the claim ``sec6-assemblies``'s own
measurement (`reference_impl.claims.sec6_assemblies`, measured once with the other claims);
what this stage adds is the test of the search itself where the mechanics is linear: on
bonded linear springs velocity Verlet's Delta t_crit is 2 / omega_max of the stiffness
matrix, and the suite's search, run on chain and lattice scenes through the compiled
assembly kernel, must reproduce it to `LINEAR_RTOL`. The same settings and search serve
the tests (`verification/test_assembly_linear.py` through `verification/_assembly_checks.py`).

Why 1e-6 relative is reachable: each normal mode of M x'' = -K x is a scalar Verlet
oscillator, bounded exactly for omega Delta t < 2 (trace of its amplification matrix
2 - (omega Delta t)^2, determinant 1), so the boundary is sharp at 2 / omega_max with no
integrator error; just above it the top mode grows by a factor 1 + sqrt(8 eps) a step
(Delta t = (1 + eps) 2 / omega_max), so within `LINEAR_CRITERION`'s 5000 steps it crosses
100 E_0 from a mode share of 1e-4 once eps > ~2e-7 (every body is given its own speed,
`body_speeds`, so that every mode has a share); the bracket is bisected to `LINEAR_GRID`'s
1e-9 of the reference step; and the confirmation level 1e6 E_0 counts a bounded orbit
below the boundary (peak at most E_0 / (1 - (omega Delta t / 2)^2)) as a runaway only
within 5e-7 of it. Each is below 1e-6.
"""

from __future__ import annotations

import math

from reference_impl.adapters.registry import parse_spec
from reference_impl.assembly.linear import dt_crit_linear
from reference_impl.assembly.model import assembly_model
from reference_impl.assembly.search import search_ensemble
from reference_impl.bench.assembly_codes import CODES, assembly_codes_table
from reference_impl.scenes import parse_scene
from reference_impl.stability.criteria import EnergyGrowth, SearchGrid

__all__ = [
    "K", "LINEAR_CRITERION", "LINEAR_GRID", "LINEAR_RTOL", "M", "body_speeds", "advice_codes",
    "code_advice", "linear_cases",
    "linear_checks", "linear_search", "scene_text",
]  # fmt: skip

# See the module docstring: horizon, confirmation and bracket of the linear checks.
LINEAR_CRITERION = EnergyGrowth(factor=100.0, n_steps=5000, confirm_factor=1e4, confirm_horizon=2)
# Coarse scan (the linear step lies between 0.2 and 1 reference step), fine bisection.
LINEAR_GRID = SearchGrid(lo=0.1, hi=1.1, step=0.1, resolution=1e-9, refine_points=4)
# The tolerance; the reasons it is reachable are in the module docstring.
LINEAR_RTOL = 1e-6

K = 1.0e6  # N/m, the springs of every linear check
M = 0.01  # kg
_RADIUS = 0.005  # m, the lattices' spheres (sets the rotational inertia)


def body_speeds(n: int) -> list[float]:
    """n distinct speeds (m/s), 0.05 to 0.15, none a rational multiple of another's pattern."""
    return [0.1 + 0.05 * math.sin(1.0 + 2.399963 * i) for i in range(n)]


def scene_text(kind_lines: str, velocities="0.1") -> str:
    """A bonded linear assembly scene: ``kind_lines`` (kind, shape) plus the spring."""
    return (
        f'name = "linear"\n{kind_lines}\nmass = {M}\nvelocities = {velocities}\n'
        f'bonded = true\n[potential]\nfamily = "power"\nk = {K}\np = 1.0\n'
    )


def linear_search(kind_lines: str) -> tuple[float, object]:
    """(Delta t_crit measured by the suite's search on the scene, every body moving (s), its
    model)."""
    n = parse_scene(scene_text(kind_lines), "<linear>").assembly.n_bodies
    text = scene_text(kind_lines, repr(body_speeds(n)))
    model = assembly_model(parse_scene(text, "<linear>"))
    ref = 2.0 * math.sqrt(M / K)  # the single contact's 2 / omega
    ens = search_ensemble(model, ref, n_lanes=1, criterion=LINEAR_CRITERION, grid=LINEAR_GRID)
    return float(ens.dt_crit[0]), model


def _lattice(name: str, cells: int, periodic: bool, tangential: bool) -> str:
    lines = f'kind = "lattice"\nlattice = "{name}"\ncells = {cells}\nradius = {_RADIUS}'
    if not periodic:
        lines += "\nperiodic = false"
    if tangential:
        lines += "\ntangential_ratio = 0.5\nrotation = true"
    return lines


def linear_cases(quick: bool = False) -> list[tuple[str, str, int | None]]:
    """(label, the scene's kind lines, N for the closed form of a chain between two walls or
    None for the stiffness matrix's eigenvalue) of the report's linear checks.

    Full: the chains of the three wall settings, the six lattices (2-D periodic, 3-D in a
    walled box of one cell) with normal springs, and the same with tangential springs
    (k_t = k / 2) and rotation. Quick: one of each kind (about a second).
    """
    chains = [(2, "both"), (2, "none"), (3, "one")] if quick else [
        (1, "both"), (2, "both"), (7, "both"), (2, "none"), (6, "none"), (3, "one"), (8, "one"),
    ]  # fmt: skip
    out = []
    for n, walls in chains:
        lines = f'kind = "chain"\nn = {n}\nwalls = "{walls}"'
        out.append((f"chain N={n}, walls {walls}", lines, n if walls == "both" else None))
    names = ("square",) if quick else ("square", "triangular", "honeycomb")
    names3 = () if quick else ("simple-cubic", "bcc", "fcc")
    for tangential in (False, True):
        what = ", tangential k_t = k/2 + rotation" if tangential else ""
        for name in names:
            out.append((f"{name} 2x2, periodic{what}", _lattice(name, 2, True, tangential), None))
        for name in names3:
            out.append((f"{name} 1 cell, walled{what}", _lattice(name, 1, False, tangential), None))
    return out


def linear_checks(quick: bool = False) -> dict:
    """The search against 2 / omega_max on every case of `linear_cases`.

    Returns
    -------
    dict
        ``rtol`` (`LINEAR_RTOL`), ``criterion`` (the runaway rule, text), ``k`` (N/m),
        ``m`` (kg) and ``rows``: per case ``case``, ``reference`` (how 2 / omega_max was
        computed), ``dt_search`` and ``dt_reference`` (s), ``rel_diff`` (|search /
        reference - 1|) and ``holds`` (rel_diff <= rtol).
    """
    rows = []
    for label, lines, n_walled in linear_cases(quick):
        got, model = linear_search(lines)
        if n_walled is not None:
            omega = 2.0 * math.sqrt(K / M) * math.sin(n_walled * math.pi / (2 * n_walled + 2))
            want, how = 2.0 / omega, "closed form 2√(k/m) sin(Nπ/(2N+2))"
        else:
            want, how = dt_crit_linear(model.assembly, K), "stiffness matrix (eigvalsh)"
        rel = abs(got / want - 1.0)
        rows.append(
            {
                "case": label,
                "reference": how,
                "dt_search": got,
                "dt_reference": want,
                "rel_diff": rel,
                "holds": bool(rel <= LINEAR_RTOL),
            }
        )
    return {
        "rtol": LINEAR_RTOL,
        "criterion": LINEAR_CRITERION.describe(),
        "k": K,
        "m": M,
        "rows": rows,
    }


def _verdict(row: dict) -> str:
    """The report's word for one advice row: safe, unsafe, or why there is none."""
    if row["safe"] is True:
        return "safe"
    if row["safe"] is False:
        return "unsafe"
    return "no advice" if row["advice"] == "none" and row["dt_crit"] is not None else "not run"


def advice_codes(adapters) -> tuple[str, ...]:
    """The codes among ``adapters`` (specs given to ``hcv report``) that run chains
    (`reference_impl.bench.assembly_codes.CODES`: the codes whose adapter runs chains), in order."""
    names: list[str] = []
    for spec in adapters:
        target, _ = parse_spec(str(spec))
        if target in CODES and target not in names:
            names.append(target)
    return tuple(names)


def code_advice(names) -> list[dict]:
    """The codes' own step advice on Hertz chains and periodic lattices (issue 39 section 4).

    Runs `reference_impl.bench.assembly_codes.assembly_codes_table` for the codes
    ``names`` (each code's measured Delta t_crit on chains of 2-5 bodies and on the
    periodic lattices of `LATTICE_SIZES`, square 4 x 4 and simple-cubic 3 x 3 x 3, and the
    advice it computes; the codes keep neighbour lists, so their lattice runs stand even
    where the suite's fixed contact list does not) and returns the rows as the report's ``assemblies.code_advice`` takes them
    (schema ``$defs/code_advice_row``: code, scene, advice, verdict, dt_advice and dt_crit
    in s, factor = dt_crit / dt_advice, note). Seconds per code and chain, ~10 s per code
    and lattice (LIGGGHTS: 22 s in all, measured at load 6).
    """
    rows = [r.to_dict() for r in assembly_codes_table(codes=tuple(names), lattices=True)]
    return [
        {
            "code": r["code"],
            "scene": r["scene"],
            "advice": r["advice"],
            "verdict": _verdict(r),
            "dt_advice": r["advice_dt"],
            "dt_crit": r["dt_crit"],
            "factor": r["factor"],
            "note": r.get("note") or None,
        }
        for r in rows
    ]
