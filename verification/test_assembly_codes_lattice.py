"""The contact codes on periodic lattices (issue 39, section 4; contract item 14).

Without a code: the lattice request refuses bad input in one line, the suite's energy of a
lattice run, the unwrapping of positions a code wrapped into its box, the scenes the codes
decline. With LIGGGHTS, LAMMPS and YADE (marked with their codes' markers, skipped with the
install line where absent): on the 4 x 4 square layer and the 3 x 3 x 3 simple-cubic
lattice the code's positions after 300 steps at the scene's 1 m/s striker are those of an
independent velocity Verlet along the actual lines of centres (the mapping of k, the
periodic images, the scheme), and those of the suite's own assembly kernel (the scene the
suite searches, which follows the lines of centres as the codes do) to round-off; the
code's Delta t_crit lies within the suite's ensemble, and its advice is what the code
computes (LIGGGHTS, YADE).
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from reference_impl.adapters._lattice_request import lattice_energy, lattice_run_from_mapping
from reference_impl.adapters.base import AdapterOutputError, LatticeRequest, LatticeRun
from reference_impl.assembly.lanes import displacements
from reference_impl.assembly.model import assembly_model
from reference_impl.bench.assembly_codes import (
    CODE_GRID,
    LATTICE_SIZES,
    assembly_codes_table,
    lattice_request,
    lattice_scene,
)
from reference_impl.errors import HCVInputError
from reference_impl.potentials.power import PowerLaw
from reference_impl.scenes import scene_toml
from verification._assembly_codes import (
    CLAIM,
    K,
    M,
    R,
    assert_advice_is_the_codes,
    assert_dt_crit_in_suite_ensemble,
    assert_run_is_verlet,
    code_fixture,
    dt_safe,
    needs,
    verlet_lattice,
)
from verification._hcv_run import hcv

from .assertions import assert_close, assert_true

# 300 steps at 0.05 Delta t_safe: the striker's contacts and the pulse into its neighbours.
STEPS, DT_FRACTION = 300, 0.05
# Positions agree with the independent Verlet to 1e-12 m: 15 printed digits (x ~ 1e-2 m:
# 1e-17 m) and the round-off of 300 steps (~1e-16 m measured); a wrong k (Hertz between
# spheres of the wrong radius, sqrt(2)) moves them by ~1e-6 m.
X_TOL = 1e-12
# Velocities: 1e-9 m/s of ~1 m/s, 15 printed digits and 300 steps (measured 3e-12 m/s).
V_TOL = 1e-9
# The suite's kernel follows the lines of centres as the codes do
# (`reference_impl.assembly.geometry`): its positions differ from a code's by round-off,
# that of positions ~1e-2 m (ulp 1.7e-18 m; the codes print 15 digits, 1e-17 m) and of the
# sums over each body's contacts, 300 steps of it: measured 3e-17 to 1.1e-16 m for the
# three codes on both lattices. Fixed normals were 6e-7 m (square) and 1.3e-6 m
# (simple-cubic) off at this 1 m/s striker.
KERNEL_X_TOL = 1e-15


def _scene(lattice: str, cells: int):
    return lattice_scene(lattice, cells)


def _square_toml(tmp_path):
    """The catalogue's triangular lattice scene written as a 4 x 4 square (a file for hcv)."""
    text = scene_toml("lattice-hertz-triangular")
    for old, new in (('"triangular"', '"square"'), ("cells = 6", "cells = 4")):
        assert old in text, f"got no {old!r} in the scene, should be one [{CLAIM}, scene_toml]"
        text = text.replace(old, new)
    path = tmp_path / "square.toml"
    path.write_text(text)
    return path


def _pair(box=(4 * R, 4 * R, 4 * R), x1=(3 * R, R, R)) -> LatticeRequest:
    """Two spheres along x in a periodic box, touching directly and across the box."""
    pos = np.array([[R, R, R], x1])
    shifts = np.array([[0.0, 0.0, 0.0], [-box[0], 0.0, 0.0]])
    return LatticeRequest("t", PowerLaw(K, 1.5), (M, M), R, pos, np.zeros((2, 3)), box,
                          (True, True, True), np.array([[0, 1], [0, 1]]), shifts, 1e-7, 10)  # fmt: skip


# -- the request, without a code ----------------------------------------------------------


@pytest.mark.parametrize(
    ("change", "words"),
    [({"x1": (3.5 * R, R, R)}, "(0, 1) is 0.0025 m off touching at the start"),
     ({"x1": (5 * R, R, R)}, "positions must lie in the box"),
     ({"box": (4 * R, 4 * R, -1.0)}, "box must be 3 edges > 0 (m)")],
)  # fmt: skip
def test_lattice_request_refuses_bad_input_in_one_line(change, words):
    with pytest.raises(HCVInputError) as exc:
        _pair(**change)
    msg = str(exc.value)
    assert_true(words in msg and "\n" not in msg, got=repr(msg), should=f"one line with {words!r}",
                claim=CLAIM, call=f"LatticeRequest {change}")  # fmt: skip


def test_lattice_energy_counts_both_images_and_unwraps_a_wrapped_body():
    req = _pair()
    q = 1e-6  # body 1 moved left by q: overlap q with body 0, a gap q across the box
    x1 = np.array([[R, R, R], [3 * R - q, R, R]])
    # body 0 wrapped across x = 0 to the far side (moved left by 3q): a gap 2q directly,
    # an overlap 2q with body 1's image across the box
    x2 = np.array([[R - 3 * q + 4 * R, R, R], [3 * R - q, R, R]])
    v = np.zeros((3, 2, 3))
    v[1, 1, 0] = -0.5
    run = lattice_run_from_mapping({"x": np.array([req.positions, x1, x2]), "v": v}, req, "c")
    assert_close(run.x[2, 0, 0], R - 3 * q, rtol=1e-12, claim=CLAIM,
                 call="lattice_run_from_mapping unwraps x")  # fmt: skip
    e = lattice_energy(req, run)
    # U = k q^(5/2) / (5/2) of each overlapping pair; 1e-9: overlaps are differences of
    # positions ~1e-2 m (1e-18 m of round-off on 1e-6 m), to the power 5/2
    assert_close(e[1], 0.5 * M * 0.25 + K / 2.5 * q**2.5, rtol=1e-9, claim=CLAIM,
                 call="lattice_energy (one overlap)")  # fmt: skip
    assert_close(e[2], K / 2.5 * (2 * q) ** 2.5, rtol=1e-9, claim=CLAIM,
                 call="lattice_energy (overlap across the box)")  # fmt: skip


def test_malformed_lattice_run_is_refused():
    req = _pair()
    with pytest.raises(AdapterOutputError, match=r"shape \(samples, 2, 3\)"):
        lattice_run_from_mapping({"x": np.zeros((5, 2, 2)), "v": np.zeros((5, 2, 2))}, req, "c")
    with pytest.raises(AdapterOutputError, match="returned 12 samples"):
        lattice_run_from_mapping(LatticeRun(np.zeros((12, 2, 3)), np.zeros((12, 2, 3))), req, "c")


def test_lattice_request_is_the_suites_scene():
    """Same bodies, contacts and start as the suite's model: every listed pair touches, a
    2-D layer is planar, the velocities are the model's."""
    for lattice, cells in LATTICE_SIZES:
        sc = _scene(lattice, cells)
        model = assembly_model(sc)
        req = lattice_request(sc, 1e-8, 10)
        d = model.assembly.dim
        assert_true(req.contacts.shape[0] == model.assembly.n_contacts
                    and req.planar == (d == 2),
                    got=f"{req.contacts.shape[0]} contacts, planar {req.planar}",
                    should=f"{model.assembly.n_contacts}, planar {d == 2}", claim=CLAIM,
                    call=f"lattice_request {sc.name}")  # fmt: skip
        assert_close(req.velocities[:, :d], model.v_init, rtol=0, atol=0, claim=CLAIM,
                     call=f"lattice_request {sc.name} velocities")  # fmt: skip


def test_hcv_dt_crit_runs_a_third_party_lattice_code(tmp_path):
    """``hcv dt-crit LATTICE --adapter CODE``: the code's Delta t_crit by the suite's search,
    beside the suite's own (same scene, horizon, rule and grid)."""
    path = _square_toml(tmp_path)
    spec = "verification._assembly_codes:VerletLatticeCode"
    r = hcv(["dt-crit", str(path), "--adapter", spec, "--json", "--horizons", "500"],
            cwd=tmp_path)  # fmt: skip
    assert_true(r.returncode == 0, got=f"exit {r.returncode}: {r.stderr[-300:]!r}",
                should="exit 0", claim=CLAIM, call=f"hcv dt-crit square --adapter {spec}")  # fmt: skip
    rep = json.loads(r.stdout)["code"]
    # the independent Verlet and the suite's kernel both follow the lines of centres:
    # round-off apart, their Delta t_crit agree to the search's resolution, two grid
    # steps (0.02 Delta t_safe) for the k-section's bracket of each
    slack = 2 * CODE_GRID.resolution * rep["dt_safe"]
    assert_true(abs(rep["dt_crit"] - rep["dt_crit_suite"]) <= slack
                and rep["n_bodies"] == 16 and rep["evidence"] in ("confirmed", "domain")
                and rep["advice"] == [],
                got=repr({k: rep[k] for k in ("dt_crit", "dt_crit_suite", "n_bodies", "advice")}),
                should=f"dt_crit within {slack:.3g} s of the suite's, 16 bodies, no advice",
                claim=CLAIM, call=f"hcv dt-crit square --adapter {spec}")  # fmt: skip


def test_codes_table_adds_the_lattices_only_when_asked():
    """`assembly_codes_table`: chains alone by default (the report's rows), the lattices of
    `LATTICE_SIZES` after them with ``lattices=True`` (a code that is not installed gives
    its one-line row on each)."""
    kw = {"codes": ("nosuchcode",), "sizes": (2,), "horizon": 200}
    plain = assembly_codes_table(**kw)
    both = assembly_codes_table(**kw, lattices=True)
    got = [(r.scene, r.n_bodies, r.coordination) for r in both]
    want = [("chain-hertz-n2", 2, 2.0), ("lattice-hertz-square-4", 16, 4.0),
            ("lattice-hertz-simple-cubic-3", 27, 6.0)]  # fmt: skip
    assert_true([r.scene for r in plain] == ["chain-hertz-n2"] and got == want
                and all("nosuchcode" in r.note and r.dt_crit_suite > 0 for r in both),
                got=repr((plain, got)), should=f"chains alone, then {want}", claim=CLAIM,
                call="assembly_codes_table(lattices=True)")  # fmt: skip


def test_chain_code_is_never_handed_a_lattice(tmp_path):
    """A code that sets supports_assembly but not supports_lattice (a chain code written
    before lattices) declines a lattice in one line, exit status 2, nothing run."""
    path = _square_toml(tmp_path)
    spec = "verification._assembly_codes:VerletChainCode"
    r = hcv(["dt-crit", str(path), "--adapter", spec], cwd=tmp_path)
    lines = r.stderr.strip().splitlines()
    words = "verlet-chain does not run lattice scenes"
    assert_true(r.returncode == 2 and len(lines) == 1 and words in lines[0] and not r.stdout,
                got=f"exit {r.returncode}, stderr {r.stderr[-300:]!r}",
                should=f"exit 2 and one line with {words!r}", claim=CLAIM,
                call=f"hcv dt-crit square --adapter {spec}")  # fmt: skip


# -- the codes ----------------------------------------------------------------------------


def _positions_match(adapter, half_step_v: bool = False):
    for lattice, cells in LATTICE_SIZES:
        sc = _scene(lattice, cells)
        req = lattice_request(sc, DT_FRACTION * dt_safe(sc), STEPS)
        run = assert_run_is_verlet(adapter, req, verlet_lattice, half_step_v=half_step_v,
                                   x_tol=X_TOL, v_tol=V_TOL, what=sc.name)  # fmt: skip
        # the scene the suite searches: its own kernel, at the same 1 m/s
        model = assembly_model(sc)
        xk = req.positions[None, :, :].repeat(STEPS + 1, axis=0)
        xk[:, :, : model.assembly.dim] += displacements(model, req.dt, STEPS)
        err = float(np.max(np.abs(run.x - xk)))
        assert_true(err <= KERNEL_X_TOL, got=f"max |x - x_kernel| = {err:.3g} m",
                    should=f"<= {KERNEL_X_TOL:g} m", claim=CLAIM,
                    call=f"{adapter.label} {sc.name} against the assembly kernel")  # fmt: skip


def _dt_crit_in_suite_ensemble(adapter):
    # 500 steps: ~28 code runs within seconds; the suite's ensemble has the same horizon
    assert_dt_crit_in_suite_ensemble(adapter, _scene("square", 4), horizon=500)


liggghts = code_fixture("liggghts")
yade = code_fixture("yade")
lammps = code_fixture("lammps")


@needs("liggghts")
def test_liggghts_lattice_is_velocity_verlet_of_the_scene(liggghts):
    _positions_match(liggghts)


@needs("liggghts")
def test_liggghts_lattice_dt_crit_lies_in_the_suites_ensemble(liggghts):
    _dt_crit_in_suite_ensemble(liggghts)


def _advice_is_the_codes_whatever_the_step(adapter, names, material):
    """The advice on the simple-cubic lattice: every name the code gives, a finite step,
    and the one that reads only the material (``material``) the same at two steps."""
    sc = _scene("simple-cubic", 3)
    assert_advice_is_the_codes(adapter, lambda dt: lattice_request(sc, dt, 200), dt_safe(sc),
                               names, material, what="lattice")  # fmt: skip


@needs("liggghts")
def test_liggghts_lattice_advice_is_its_rayleigh_and_hertz_times(liggghts):
    _advice_is_the_codes_whatever_the_step(liggghts, ("rayleigh", "hertz"), "rayleigh")


@needs("yade")
def test_yade_lattice_is_leapfrog_of_the_scene(yade):
    # leapfrog: the positions of velocity Verlet, the velocity of the half step
    _positions_match(yade, half_step_v=True)


@needs("yade")
def test_yade_lattice_dt_crit_lies_in_the_suites_ensemble(yade):
    _dt_crit_in_suite_ensemble(yade)


@needs("yade")
def test_yade_lattice_advice_is_pwave_and_global_stiffness(yade):
    _advice_is_the_codes_whatever_the_step(
        yade, ("PWaveTimeStep", "GlobalStiffnessTimeStepper"), "PWaveTimeStep"
    )


@needs("lammps")
def test_lammps_lattice_is_velocity_verlet_of_the_scene(lammps):
    _positions_match(lammps)


@needs("lammps")
def test_lammps_lattice_dt_crit_lies_in_the_suites_ensemble(lammps):
    _dt_crit_in_suite_ensemble(lammps)
