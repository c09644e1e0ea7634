"""What the adapter tests share: small scenes, the scripted adapter's command, one metric.

`test_adapters.py`, `test_hostile_bench.py` and `test_hostile_bench_processes.py` build
their cases from `scene`, `ascene` and `cmd`; the three code test modules
(`test_lammps.py`, `test_kratos.py`, `test_mujoco.py`) take catalogue scenes at a
resolution with `scene_at`.
"""

from __future__ import annotations

import sys
from pathlib import Path

from reference_impl.adapters import AdapterScene
from reference_impl.bench.scorecard.runner import resolve_scenes
from reference_impl.exact.solve import solve_impact
from reference_impl.scenes import parse_scene

__all__ = ["FAST", "HCV_BENCH", "SCRIPT", "ascene", "by", "cmd", "scene", "scene_at", "scene_text"]

SCRIPT = Path(__file__).resolve().parent / "_adapter_script.py"
# `hcv bench` in a child process (the caller sets PYTHONPATH and the working directory).
HCV_BENCH = (sys.executable, "-m", "reference_impl.cli", "bench")

# Small scenes keep every benchmark run of the adapter tests to a second or two.
_SCENE = """
name = "{name}"
mass = 4.1103e-3
velocities = {vels}
kind = "impact"
[potential]
family = "power"
k = 1.0879e10
p = 1.5
{damping}
"""
_DAMPED = '[damping]\nlaw = "universal"\nzeta = 0.1'
# Coarser critical-step bisection and a shorter speed table than the defaults.
FAST = {"dt_crit": {"resolution": 0.05}, "run": {"speed_error_steps": [50, 100, 200]}}


def scene_text(name="small", vels=(0.5, 2.0), damped=True) -> str:
    """The TOML of a small Hertz impact scene (damped: zeta = 0.1) at ``vels`` [m/s]."""
    return _SCENE.format(name=name, vels=list(vels), damping=_DAMPED if damped else "")


def scene(name="small", vels=(0.5, 2.0), damped=True):
    """`scene_text`'s scene, parsed."""
    return parse_scene(scene_text(name, vels, damped), f"<test>/{name}.toml")


def cmd(*args) -> str:
    """The ``cmd:`` spec of the scripted adapter (`_adapter_script.py`) with ``args``."""
    return "cmd:" + " ".join([sys.executable, str(SCRIPT), *args])


def ascene(v0=1.0, damped=True, n_per_contact=200):
    """`scene` as an `AdapterScene` at ``v0`` [m/s], ``n_per_contact`` steps per contact."""
    sc = scene(damped=damped)
    t_c = solve_impact(sc.potential, sc.mass, v0, sc.zeta or 0.0).contact_time
    dt = t_c / n_per_contact
    return AdapterScene.from_scene(sc, v0, dt, 4 * n_per_contact)


def by(result, scene_name, metric):
    """The metric result of ``scene_name`` named ``metric`` in a bench result."""
    return next(m for m in result.metrics if m.scene == scene_name and m.metric == metric)


def scene_at(
    name: str, v0: float, steps_per_contact: int = 200, zeta=None, extra_steps: int = 0
) -> AdapterScene:
    """Catalogue scene ``name`` at ``v0`` [m/s] with dt = exact contact time / steps_per_contact.

    The run lasts 4 contact times plus ``extra_steps`` steps; ``zeta`` (optional) replaces
    the scene's damping (0: undamped).
    """
    sc = resolve_scenes([name])[0]
    t_c = solve_impact(sc.potential, sc.mass, v0, sc.zeta or 0.0).contact_time
    n_steps = 4 * steps_per_contact + extra_steps
    asc = AdapterScene.from_scene(sc, v0, t_c / steps_per_contact, n_steps)
    if zeta is not None:
        asc = asc.replace(zeta=zeta, damping="universal" if zeta else "none")
    return asc
