"""Our Verlet lane engine against LAMMPS (and Kratos DEM) on the same collision and time step.

Run:  /work/venv/bin/python -m benchmarks.bench_lammps [--quick] [--json FILE]

The collision: the hertz scene's 10 mm steel sphere (k = 1.0879e10 N/m^1.5,
m = 4.1103e-3 kg) on a wall, LAMMPS ``fix wall/gran granular hertz ... damping
coeff_restitution`` with e = exp(-pi 0.1 / sqrt(1 - 0.01)), which is exactly the
universal law with zeta = 0.1 (see reference_impl/adapters/lammps.py), so both
codes integrate the same equation with the same scheme; a batch of impact
speeds log-spaced in [0.1, 5] m/s, one common dt = (contact time at 5 m/s) / 200.

Measured in one process, each the best of a few repeats (wall time):

* ours: `run_lanes` (numba kernel, one lane per speed, serial);
* LAMMPS per collision: one LAMMPS run per speed, driven as the adapter does
  (new instance, input script, run to separation, trajectory extracted);
* LAMMPS batch: one LAMMPS run with one atom per speed (spaced apart, no pair
  interaction), run for the step count of the slowest collision.

* Kratos DEM per collision (when ``.[kratos]`` is installed): one run of the
  kratos adapter per speed (``DEM_D_Hertz_viscous_Coulomb``, Velocity_Verlet; its
  own law: tension clipped, Thornton's gamma, so its restitution is not compared).

Reported: steps per second (lane-steps or atom-steps) and collisions per second,
the ratios, and the largest restitution difference between the codes (the same
scheme: round-off). Goal (issue): ours >= 100 x LAMMPS collisions per second.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import math  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from benchmarks._machine import machine_info  # noqa: E402
from benchmarks._record import write_json  # noqa: E402
from reference_impl import solve_impact  # noqa: E402
from reference_impl.adapters.base import AdapterScene  # noqa: E402
from reference_impl.adapters.lammps import LammpsAdapter, load_lammps  # noqa: E402
from reference_impl.integrators.verlet import SCENE_IMPACT, LaneBatch, run_lanes  # noqa: E402
from reference_impl.scenes import load_scene  # noqa: E402

_ZETA = 0.1  # the hertz-damped scene's
_STEPS_PER_CONTACT = 200
_REPEATS = 3


def _best(fn, repeats=_REPEATS):
    best, out = math.inf, None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def ours(pot, m, vels, dt, n_steps):
    """(seconds, lane-steps, restitutions) of the lane engine on the batch."""
    batch = LaneBatch(dt=np.full(vels.size, dt), y0=0.0, v0=vels, e_limit=np.inf, max_steps=n_steps)
    run_lanes(pot, m, SCENE_IMPACT, batch, zeta=_ZETA)  # compile / warm up
    secs, res = _best(lambda: run_lanes(pot, m, SCENE_IMPACT, batch, zeta=_ZETA))
    e = np.sqrt(res.e_end / (0.5 * m * vels**2))
    return secs, int(res.steps.sum()), e


def lammps_per_collision(scene, vels, dt, n_steps):
    """(seconds, steps, restitutions) of one adapter-style LAMMPS run per speed."""
    adapter = LammpsAdapter(damping="coeff_restitution", geometry="wall")
    scenes = [AdapterScene.from_scene(scene, v, dt, n_steps) for v in vels]
    adapter.impact(scenes[0])  # load the library once

    def run():
        return [adapter.impact(s) for s in scenes]

    secs, trajs = _best(run)
    adapter.close()
    steps = sum(int(t.t.size - 1) for t in trajs)
    e = np.array([-t.v[-1] / v for t, v in zip(trajs, vels, strict=True)])
    return secs, steps, e


def kratos_per_collision(scene, vels, dt, n_steps):
    """(seconds, steps) of one kratos-adapter run per speed, or None without Kratos."""
    from reference_impl.adapters.kratos import KratosAdapter, kratos_available

    if kratos_available() is not None:
        return None
    adapter = KratosAdapter(law="hertz", scheme="verlet")
    scenes = [AdapterScene.from_scene(scene, v, dt, n_steps) for v in vels]
    adapter.impact(scenes[0])  # load the library once

    secs, trajs = _best(lambda: [adapter.impact(s) for s in scenes])
    return secs, sum(int(t.t.size - 1) for t in trajs)


def lammps_batch(scene, vels, dt, n_steps):
    """(setup s, run s, atom-steps, restitutions) of one LAMMPS run with one atom per speed."""
    module = load_lammps()
    adapter = LammpsAdapter(damping="coeff_restitution", geometry="wall")
    lam = adapter._mapping(AdapterScene.from_scene(scene, vels[0], dt, n_steps))
    R = lam["R"]
    coeffs = (
        f"hertz {lam['k_n']!r} {lam['coef']!r} tangential linear_nohistory 0.0 0.0 "
        "damping coeff_restitution"
    )
    n = vels.size

    def run():
        t0 = time.perf_counter()
        lmp = module.lammps(cmdargs=["-log", "none", "-screen", "none", "-nocite"])
        lines = [
            "units si",
            "atom_style sphere",
            "atom_modify map array",
            "boundary m m m",
            f"region box block 0 {3.0 * R * n!r} {-2 * R!r} {2 * R!r} 0 {4 * R!r}",
            "create_box 1 box",
        ]
        lines += [f"create_atoms 1 single {3.0 * R * i!r} 0.0 {R!r} units box" for i in range(n)]
        lines += [f"set type 1 diameter {2 * R!r}", f"set type 1 mass {lam['atom_mass']!r}"]
        lines += [f"set atom {i + 1} vz {-float(v)!r}" for i, v in enumerate(vels)]
        lines += [
            "fix int all nve/sphere",
            f"fix wall all wall/gran granular {coeffs} zplane 0.0 NULL",
            f"timestep {dt!r}",
            "thermo 0",
            "run 0",
        ]
        lmp.commands_string("\n".join(lines))
        t1 = time.perf_counter()
        lmp.command(f"run {n_steps} pre no post no")
        t2 = time.perf_counter()
        ids = np.array(lmp.numpy.extract_atom("id"))
        vz = np.array(lmp.numpy.extract_atom("v"))[:, 2]
        e = np.empty(n)
        e[ids - 1] = vz / vels[ids - 1]
        lmp.close()
        return t1 - t0, t2 - t1, e

    results = [run() for _ in range(_REPEATS)]
    setup = min(r[0] for r in results)
    secs = min(r[1] for r in results)
    adapter.close()
    return setup, secs, n * n_steps, results[0][2]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="smaller batches")
    ap.add_argument("--json", help="write the results as JSON here")
    args = ap.parse_args(argv)
    scene = load_scene(
        "hertz-damped"
    )  # zeta = 0.1: LAMMPS gets e = exp(-pi zeta / sqrt(1 - zeta^2))
    pot, m = scene.potential, scene.mass
    n_batch = 200 if args.quick else 1000
    n_single = 20 if args.quick else 100
    vels = np.geomspace(0.1, 5.0, n_batch)
    dt = solve_impact(pot, m, 5.0, _ZETA).contact_time / _STEPS_PER_CONTACT
    t_slow = solve_impact(pot, m, 0.1, _ZETA).contact_time
    n_steps = int(math.ceil(1.2 * t_slow / dt)) + 8

    info = machine_info()
    print(
        f"machine: {info['platform']}, {info['cpu_count']} cores, python {info['python']}, "
        f"commit {info['commit']}"
    )
    print(
        f"collision: hertz k = {pot.k:g} N/m^1.5, m = {m:g} kg, universal damping zeta = "
        f"{_ZETA} (LAMMPS coeff_restitution), dt = {dt:.4g} s, {n_batch} speeds in [0.1, 5] m/s"
    )

    s_ours, steps_ours, e_ours = ours(pot, m, vels, dt, n_steps)
    sub = vels[np.linspace(0, n_batch - 1, n_single).astype(int)]
    s_one, steps_one, e_one = lammps_per_collision(scene, sub, dt, n_steps)
    setup_b, s_batch, steps_batch, e_batch = lammps_batch(scene, vels, dt, n_steps)

    rows = {
        "ours (lane engine)": (steps_ours / s_ours, n_batch / s_ours),
        "LAMMPS, one run per collision": (steps_one / s_one, n_single / s_one),
        "LAMMPS, batch (run only)": (steps_batch / s_batch, n_batch / s_batch),
        "LAMMPS, batch (with setup)": (
            steps_batch / (s_batch + setup_b),
            n_batch / (s_batch + setup_b),
        ),
    }
    kratos = kratos_per_collision(scene, sub, dt, n_steps)
    if kratos is not None:
        rows["Kratos DEM, one run per collision"] = (kratos[1] / kratos[0], n_single / kratos[0])
    print(f"{'':32s} {'steps/s':>12s} {'collisions/s':>14s} {'ours / this':>12s}")
    for name, (sps, cps) in rows.items():
        ratio = rows["ours (lane engine)"][1] / cps
        print(f"{name:32s} {sps:12.4g} {cps:14.4g} {ratio:12.4g}")
    idx = np.linspace(0, n_batch - 1, n_single).astype(int)
    diff_one = float(np.max(np.abs(e_one - e_ours[idx])))
    diff_batch = float(np.max(np.abs(e_batch - e_ours)))
    print(
        f"restitution: ours {e_ours.min():.12f} .. {e_ours.max():.12f}; max |LAMMPS - ours| "
        f"= {diff_one:.2e} (per collision), {diff_batch:.2e} (batch)"
    )
    ratio_adapter = rows["ours (lane engine)"][1] / rows["LAMMPS, one run per collision"][1]
    ratio_batch = rows["ours (lane engine)"][1] / rows["LAMMPS, batch (run only)"][1]
    print(
        f"goal ours >= 100 x LAMMPS collisions/s: {ratio_adapter:.0f} x per-collision LAMMPS "
        f"({'met' if ratio_adapter >= 100 else 'NOT met'}), {ratio_batch:.1f} x batched LAMMPS "
        f"({'met' if ratio_batch >= 100 else 'NOT met'})"
    )
    if args.json:
        out = {
            "machine": info,
            "dt": dt,
            "n_batch": n_batch,
            "n_single": n_single,
            "n_steps": n_steps,
            "rates": {k: {"steps_per_s": a, "collisions_per_s": b} for k, (a, b) in rows.items()},
            "ratio_vs_per_collision": ratio_adapter,
            "ratio_vs_batch": ratio_batch,
            "max_restitution_difference": max(diff_one, diff_batch),
        }
        write_json(args.json, out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
