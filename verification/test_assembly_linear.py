"""The critical-step search on assemblies, checked where it is exact (issue 39, section 2).

Bonded linear springs: velocity Verlet's Delta t_crit is 2 / omega_max of the stiffness
matrix (`verification/_assembly_checks.py` says why 1e-6 is reachable). The suite's search,
run on chain and lattice scenes through the compiled assembly kernel, must give it to
1e-6: chains with walls at both ends against the closed form, free and one-wall chains
against a tridiagonal matrix built here, the five Bravais lattices (periodic) against
Bloch eigenvalues built here from their neighbour vectors, honeycomb and the walled
lattices and the tangential springs with rotation against
`reference_impl.assembly.linear` (a dense matrix assembled independently of the kernel).
One body between two walls reproduces the single-contact search bit for bit.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from reference_impl.assembly import geometry
from reference_impl.assembly.lanes import AssemblyModel, run_lanes
from reference_impl.assembly.linear import dt_crit_linear
from reference_impl.assembly.search import search_ensemble
from reference_impl.integrators.verlet import SCENE_WALLS, LaneBatch
from reference_impl.integrators.verlet import run_lanes as single_lanes
from reference_impl.potentials import PowerLaw
from reference_impl.stability.criteria import EnergyGrowth, SearchGrid
from reference_impl.stability.search import search_scene
from verification._assembly_checks import LINEAR_RTOL, K, M, linear_search
from verification.assertions import assert_close, assert_true

_CLAIM = "assembly linear Delta t_crit"


def _check(kind_lines: str, want: float) -> None:
    got, _ = linear_search(kind_lines)
    assert_close(got, want, rtol=LINEAR_RTOL, claim=_CLAIM, call=kind_lines.replace("\n", " "))


# ---------------------------------------------------------------------------- chains
@pytest.mark.parametrize("n", [1, 2, 7])
def test_chain_between_walls_gives_the_closed_form(n):
    """omega_max = 2 sqrt(k/m) sin(N pi / (2N + 2)) for N bodies between two walls."""
    omega = 2.0 * math.sqrt(K / M) * math.sin(n * math.pi / (2 * n + 2))
    _check(f'kind = "chain"\nn = {n}\nwalls = "both"', 2.0 / omega)


def _tridiagonal(n: int, walls: int) -> float:
    """2 / omega_max of N bodies in a row, free ends (walls 0) or one wall at the right (1)."""
    diag = np.full(n, 2.0)
    diag[0] = 1.0
    diag[-1] = 1.0 + walls
    if n == 1:
        diag[0] = float(walls)
    Kmat = np.diag(diag) - np.diag(np.ones(n - 1), 1) - np.diag(np.ones(n - 1), -1)
    return 2.0 / math.sqrt(np.linalg.eigvalsh(Kmat * K / M)[-1])


@pytest.mark.parametrize("n, walls", [(2, "none"), (6, "none"), (3, "one"), (8, "one")])
def test_free_and_one_wall_chains_give_the_tridiagonal_eigenvalue(n, walls):
    want = _tridiagonal(n, 0 if walls == "none" else 1)
    _check(f'kind = "chain"\nn = {n}\nwalls = "{walls}"', want)


# --------------------------------------------------------------------------- lattices
_S3 = math.sqrt(3.0)
# Bravais lattices, unit nearest-neighbour distance: the conventional box vectors (rows) of
# the scene's cells and every neighbour vector, written here from their textbook forms.
_BRAVAIS = {
    "square": (np.eye(2), [(1, 0), (-1, 0), (0, 1), (0, -1)]),
    "triangular": (
        np.array([[1.0, 0.0], [0.5, _S3 / 2]]),
        [(math.cos(a), math.sin(a)) for a in np.arange(6) * math.pi / 3],
    ),
    "simple-cubic": (np.eye(3), [s * e for e in np.eye(3) for s in (1, -1)]),
    "bcc": (
        np.eye(3) * 2 / _S3,
        [np.array(s) / _S3 for s in itertools.product((1, -1), repeat=3)],
    ),
    "fcc": (
        np.eye(3) * math.sqrt(2.0),
        [
            np.array(v) / math.sqrt(2.0)
            for v in set(itertools.permutations((1, 1, 0)))
            | set(itertools.permutations((1, -1, 0)))
            | set(itertools.permutations((-1, -1, 0)))
        ],
    ),  # fmt: skip
}


def _bloch(name: str, cells: int) -> float:
    """2 / omega_max over the k-points of a periodic box of ``cells`` conventional cells."""
    box, deltas = _BRAVAIS[name]
    deltas = [np.asarray(d, dtype=float) for d in deltas]
    recip = 2 * math.pi * np.linalg.inv(box).T  # rows b_i with a_i . b_j = 2 pi delta_ij
    dim = box.shape[0]
    # a conventional cell of bcc / fcc holds 2 / 4 lattice points: the box's k-points are
    # those of its conventional lattice, whose Brillouin zone folds the Bravais one
    top = 0.0
    for ms in itertools.product(range(cells), repeat=dim):
        kvec = sum(m * b for m, b in zip(ms, recip, strict=False)) / cells
        for shift in itertools.product(range(2), repeat=dim) if name in ("bcc", "fcc") else [()]:
            kk = kvec + (sum(s * b for s, b in zip(shift, recip, strict=False)) if shift else 0.0)
            D = sum((1 - math.cos(kk @ d)) * np.outer(d, d) for d in deltas) * K / M
            top = max(top, float(np.linalg.eigvalsh(D)[-1]))
    return 2.0 / math.sqrt(top)


@pytest.mark.parametrize("name", list(_BRAVAIS))
def test_periodic_bravais_lattice_gives_its_bloch_eigenvalue(name):
    _check(f'kind = "lattice"\nlattice = "{name}"\ncells = 2\nradius = 0.005', _bloch(name, 2))


def _matrix_case(kind_lines: str) -> None:
    got, model = linear_search(kind_lines)
    want = dt_crit_linear(model.assembly, K)
    assert_close(got, want, rtol=LINEAR_RTOL, claim=_CLAIM, call=kind_lines.replace("\n", " "))


_SMALL = {"square": 2, "triangular": 2, "honeycomb": 2, "simple-cubic": 1, "bcc": 1, "fcc": 1}


@pytest.mark.parametrize("name", geometry.LATTICES)
def test_walled_lattice_gives_its_stiffness_eigenvalue(name):
    _matrix_case(
        f'kind = "lattice"\nlattice = "{name}"\ncells = {_SMALL[name]}\nradius = 0.005\n'
        "periodic = false"
    )


def test_periodic_honeycomb_gives_its_stiffness_eigenvalue():
    _matrix_case('kind = "lattice"\nlattice = "honeycomb"\ncells = 2\nradius = 0.005')


@pytest.mark.parametrize("name", geometry.LATTICES)
def test_tangential_springs_with_rotation_give_the_stiffness_eigenvalue(name):
    box = "" if _SMALL[name] == 2 else "periodic = false\n"
    _matrix_case(
        f'kind = "lattice"\nlattice = "{name}"\ncells = {_SMALL[name]}\nradius = 0.005\n{box}'
        "tangential_ratio = 0.5\nrotation = true"
    )


def test_the_bloch_reference_is_the_stiffness_matrix_of_the_periodic_box():
    """The test's own Bloch eigenvalue and the package's dense matrix agree (both references)."""
    for name in _BRAVAIS:
        asm = geometry.lattice(name, 2, M, 0.005)
        assert_close(dt_crit_linear(asm, K), _bloch(name, 2), rtol=1e-12, claim=_CLAIM,
                     call=f"dt_crit_linear(lattice({name!r}, 2))")  # fmt: skip


# --------------------------------------------------------------- one body, two walls
_HERTZ = PowerLaw(1.0879e10, 1.5)
_MASS, _GAP, _V0 = 4.1103e-3, 1.0e-4, 1.0


def _one_body(zeta: float = 0.0) -> AssemblyModel:
    asm = geometry.chain([_MASS], "both", _GAP)
    return AssemblyModel(asm, _HERTZ, False, zeta, 0.0, np.array([[_V0]]), np.zeros((1, 0)))


@pytest.mark.parametrize("zeta", [0.0, 0.1])
def test_one_body_between_walls_runs_bit_for_bit_as_the_single_contact_lanes(zeta):
    """Undamped and with the universal dashpot (c = 2 zeta sqrt(m) at a wall)."""
    dts = np.linspace(2e-7, 3e-6, 24)
    n = dts.size
    crit = dict(factor=100.0, confirm_level=1e6, n_steps=3000, confirm_steps=30000)
    got = run_lanes(_one_body(zeta), dts, 1.0, **crit)
    E0 = 0.5 * _MASS * _V0**2
    batch = LaneBatch(
        dt=dts, y0=np.full(n, _GAP), v0=np.full(n, _V0), gap=np.full(n, _GAP),
        e_limit=np.full(n, 100.0 * E0), e_final=np.full(n, np.inf),
        max_steps=np.full(n, 3000), group=np.zeros(n, dtype=np.int64),
        e_confirm=np.full(n, 1e6 * E0), confirm_steps=np.full(n, 30000),
    )  # fmt: skip
    want = single_lanes(_HERTZ, _MASS, SCENE_WALLS, batch, zeta=zeta)
    same = (
        np.array_equal(got.status, want.status)
        and np.array_equal(got.steps, want.steps)
        and np.array_equal(got.e_max, want.e_max)
        and np.array_equal(got.e_end, want.e_end, equal_nan=True)
    )
    assert_true(
        same,
        got=f"status {got.status.tolist()}, E_max {got.e_max[:3].tolist()}",
        should=f"status {want.status.tolist()}, E_max {want.e_max[:3].tolist()}",
        claim=_CLAIM,
        call="run_lanes(chain n=1, walls both) vs verlet.run_lanes(two-walls)",
    )


def test_one_body_between_walls_gives_the_single_contact_search_exactly():
    """N = 1: the assembly search's bracket is the single-contact search's, to the bit."""
    crit = EnergyGrowth(factor=100.0, n_steps=3000, confirm_factor=1e4, confirm_horizon=2)
    grid = SearchGrid()
    single = search_scene(_HERTZ, _MASS, [_V0], "two-walls", gap=_GAP, criterion=crit,
                          grid=grid, recommend=None)[0]  # fmt: skip
    ens = search_ensemble(_one_body(), single.dt_safe, n_lanes=1, criterion=crit, grid=grid)
    got = (float(ens.dt_stable[0]), float(ens.dt_crit[0]))
    want = (single.dt_stable, single.dt_crit)
    assert_true(
        got == want and math.isfinite(want[1]),
        got=f"(dt_stable, dt_crit) = {got}",
        should=f"{want}, the single-contact search's (a finite failure)",
        claim=_CLAIM,
        call="search_ensemble(chain n=1) vs search_scene(two-walls)",
    )
