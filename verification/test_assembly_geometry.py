"""The contact geometry of assemblies: lines of centres followed, normals fixed (issue 39).

A lattice's contacts follow their lines of centres (finite displacements, as LIGGGHTS,
LAMMPS and YADE run them, `reference_impl.assembly.geometry`): the overlaps against
2 R - |x_j - x_i| computed here, the kernel's positions against an independent velocity
Verlet along the actual lines of centres (`verification._lattice_codes.verlet_lattice`,
numpy, nothing of the kernel) at the 1 m/s striker of ``lattice-hertz``. A chain runs its
fixed normals (its lines of centres cannot turn), and following them changes it by
round-off only; bonded springs keep fixed normals (their linear theory is about small
displacements).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from reference_impl.assembly import geometry
from reference_impl.assembly.lanes import (
    AssemblyModel,
    cage_fraction,
    displacements,
    initial_energy,
)
from reference_impl.assembly.model import assembly_model
from reference_impl.assembly.safe import dt_safe_conventions
from reference_impl.assembly.search import assembly_report
from reference_impl.bench.assembly_codes import LATTICE_SIZES, lattice_request, lattice_scene
from reference_impl.potentials import PowerLaw
from reference_impl.scenes import scene_from_dict
from reference_impl.stability.criteria import SearchGrid
from verification._assembly_codes import verlet_lattice

from .assertions import assert_close, assert_true

CLAIM = "assembly geometry"
K, M, R = 1.0879e10, 4.1103e-3, 5e-3  # the lattice-hertz scenes: N/m^1.5, kg, m
# 300 steps at 0.05 Delta t_safe: the striker's contacts and the pulse into its neighbours
# (|u| up to ~9e-5 m), as the codes' lattice checks run.
STEPS, DT_FRACTION = 300, 0.05
# A few coarse steps: the search runs only to say which model it ran.
_COARSE = SearchGrid(lo=0.5, hi=1.0, step=0.5, resolution=0.25, refine_points=2)


def test_overlaps_follow_the_line_of_centres_and_walls_keep_their_normal():
    """q = 2 R - |L n + u_j - u_i| between bodies; off + u_i . n at a wall, in both models."""
    asm = geometry.lattice("simple-cubic", 2, M, R, periodic=False)
    u = np.random.default_rng(39).uniform(-1e-5, 1e-5, (asm.n_bodies, 3))
    fol, fix = geometry.overlaps(asm, u, True), geometry.overlaps(asm, u, False)
    body = asm.cj >= 0
    uj = u[np.maximum(asm.cj, 0)]
    sep = np.linalg.norm(2 * R * asm.normal + uj - u[asm.ci], axis=1)
    # 1e-16 m: the direct 2 R - |...| cancels two numbers ~1e-2 m (ulp 1.7e-18 m) and the
    # squares and root carry a few ulps more; overlaps here are ~1e-5 m
    assert_close(fol[body], 2 * R - sep[body], rtol=0, atol=1e-16, claim=CLAIM,
                 call="overlaps(follow=True) between bodies")  # fmt: skip
    wall = asm.off + np.sum(u[asm.ci] * asm.normal, axis=1)
    assert_close(fol[~body], wall[~body], rtol=0, atol=0, claim=CLAIM,
                 call="overlaps(follow=True) at walls")  # fmt: skip
    assert_close(fix[~body], wall[~body], rtol=0, atol=0, claim=CLAIM,
                 call="overlaps(follow=False) at walls")  # fmt: skip
    # the two differ between bodies by the turning of the line: -|du_t|^2 / (2 L) to
    # second order, the next term du_n / L ~ 3e-3 of it (1e-2 relative allows for it);
    # 1e-16 m absolute for the round-off above
    du = (uj - u[asm.ci])[body]
    dn = np.sum(du * asm.normal[body], axis=1)
    turn = -(np.sum(du * du, axis=1) - dn * dn) / (2 * 2 * R)
    assert_close(fol[body] - fix[body], turn, rtol=1e-2, atol=1e-16, claim=CLAIM,
                 call="overlaps(follow) - overlaps(fixed)")  # fmt: skip


def _dt_safe(model) -> float:
    return dt_safe_conventions(model, initial_energy(model))["paper"]


@pytest.mark.parametrize(("lattice", "cells"), LATTICE_SIZES)
def test_lattice_kernel_is_velocity_verlet_along_the_lines_of_centres(lattice, cells):
    """At 1 m/s the kernel's positions are an independent Verlet's to round-off (fixed
    normals were 6e-7 m off here)."""
    sc = lattice_scene(lattice, cells)
    model = assembly_model(sc)
    req = lattice_request(sc, DT_FRACTION * _dt_safe(model), STEPS)
    x, _, _ = verlet_lattice(req)
    d = model.assembly.dim
    u = displacements(model, req.dt, STEPS)
    err = float(np.max(np.abs(req.positions[None, :, :d] + u - x[:, :, :d])))
    # 1e-15 m: positions ~1e-2 m carry ulps of 1.7e-18 m; a sum over each body's Z
    # contacts and 300 steps of it, measured 7e-17 m; the line of centres left fixed moves
    # them by ~6e-7 m, a wrong image or sign by far more
    assert_true(err <= 1e-15 and model.follows, got=f"max |x_kernel - x_verlet| = {err:.3g} m",
                should="<= 1e-15 m, following the lines of centres", claim=CLAIM,
                call=f"displacements({sc.name})")  # fmt: skip


def test_a_chain_runs_its_fixed_normals_and_following_them_changes_round_off_only():
    masses = [M] * 5
    asm = geometry.chain(masses, "both", 1e-5)
    v = np.zeros((5, 1))
    v[0, 0] = 1.0
    model = AssemblyModel(asm, PowerLaw(K, 1.5), False, 0.05, 0.0, v, np.zeros((5, 0)))
    # length 2 R between bodies, 0 at the walls: the follow path, along the x axis
    lc = np.where(asm.cj >= 0, 2 * R + 1e-5, 0.0)
    follow = dataclasses.replace(model, assembly=dataclasses.replace(asm, length=lc))
    dt = 0.05 * _dt_safe(model)
    a, b = displacements(model, dt, 2000), displacements(follow, dt, 2000)
    # 1e-17 m: the follow path rounds L - |L + du| (L ~1e-2 m, ulp 1.7e-18 m) where the
    # fixed one takes du, each step's few ulps, summed through the 2000 steps of pulses
    assert_true(model.kernel_lengths() is None and follow.kernel_lengths() is not None,
                got=f"{model.kernel_lengths()!r}, {follow.kernel_lengths()!r}",
                should="None (a chain's fixed normals), then the lengths", claim=CLAIM,
                call="AssemblyModel.kernel_lengths")  # fmt: skip
    assert_close(b, a, rtol=0, atol=1e-17, claim=CLAIM, call="displacements(chain, follow)")


def test_bonded_springs_keep_fixed_normals_and_contact_laws_follow():
    """The default: bonded springs (the linear checks' small-displacement theory) keep fixed
    normals; the report of a search says which model ran."""
    got = {}
    for bonded in (True, False):
        d = lattice_scene("square", 2).to_dict()
        d.pop("source", None)
        d["bonded"] = bonded
        model = assembly_model(scene_from_dict(d))
        rep = assembly_report(model, horizons=(20,), n_lanes=1, grid=_COARSE)
        got[bonded] = (model.follows, rep["geometry"])
    want = {True: (False, "fixed normals"), False: (True, "lines of centres")}
    assert_true(got == want, got=repr(got), should=repr(want), claim=CLAIM,
                call="assembly_model(square, bonded).follows, assembly_report geometry")  # fmt: skip


def test_cage_is_half_the_second_neighbours_clearance_and_a_loose_layer_leaves_it():
    """cage = (d_2 - 2 R) / 2; at 1 m/s over 1000 steps a touching square layer (rows slide
    freely, no pressure) comes apart, a close-packed triangular one stays caged."""
    want = {"square": (2**0.5 - 1) * R, "triangular": (3**0.5 - 1) * R,
            "bcc": (2 / 3**0.5 - 1) * R, "fcc": (2**0.5 - 1) * R}  # fmt: skip
    got = {name: geometry.lattice(name, 2, M, R).cage for name in want}
    # 1e-12: d_2 from products of sqrt(2), sqrt(3) (a few ulps), over a difference ~0.1-0.7
    for name in want:
        assert_close(got[name], want[name], rtol=1e-12, claim=CLAIM, call=f"lattice({name!r}).cage")
    frac = {}
    for name in ("square", "triangular"):
        asm = geometry.lattice(name, 2, M, R)
        v = np.zeros((asm.n_bodies, 2))
        v[0] = (0.9, 0.3 * 2**0.5)  # 1 m/s, off the lattice directions
        model = AssemblyModel(
            asm, PowerLaw(K, 1.5), False, 0.0, 0.0, v, np.zeros((asm.n_bodies, 0))
        )
        frac[name] = cage_fraction(model, 0.3 * _dt_safe(model), 1000, every=10)
    assert_true(frac["square"] > 1.0 and frac["triangular"] < 0.01, got=repr(frac),
                should="square > 1 (left), triangular < 0.01", claim=CLAIM,
                call="cage_fraction(2x2, 1000 steps at 0.3 Delta t_safe)")  # fmt: skip
