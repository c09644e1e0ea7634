"""The benchmark run loop: scenes through an adapter and through the exact solution.

For every adapter variant and scene, and every impact speed of the scene:

1. the main run at dt = (exact contact time) / steps_per_contact;
2. the law the code implements (``implemented_law``) and its exact solution;
3. a critical-step search on the code: increasing dt until the rebound energy
   exceeds (1 + gain_tol) E_0, the run blows up or fails, then bisection;

then, at the middle speed, the speed-against-error table (several dt, wall time
of each run, errors against the exact solution), and for two-walls scenes one
long elastic run (energy drift). The metrics of `reference_impl.bench.scorecard.metrics`
are evaluated on the records.

Isolation: every adapter call goes through an executor
(`reference_impl.bench.worker`); a crash, hang or malformed output fails that
run only, with its one-line reason and stderr, and the loop goes on. Results are
kept in the `BenchResult` as they come; with ``json_path`` the JSON file is
rewritten after every scene (and on interruption), so nothing computed is lost.

Here: the run of one variant on one scene (`_SceneRun`) and the loop over the cells
(`run_bench`). Elsewhere, importable from here: the scenes and the cells
(`reference_impl.bench.scorecard._plan`), the records (`reference_impl.bench.scorecard._records`). Private:
the critical-step search (`_dtcrit`), textbook Verlet's baselines (`_textbook`), the
early ends of a scene run (`_errors`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

import numpy as np

from reference_impl.adapters.base import (
    AdapterScene,
    ImplementedLaw,
    Trajectory,
    offset_refusal,
    scheme_of,
)
from reference_impl.adapters.law_damping import implemented_law_from_table, law_of
from reference_impl.bench.measure import (
    check_conventions,
    check_declared_law,
    contact_sample_times,
    exact_peak_force,
    exact_reference,
    exact_tensile_on_samples,
    measure,
    rigid_bounce,
)
from reference_impl.bench.scorecard._dtcrit import _EXTRA_STEPS, dt_crit
from reference_impl.bench.scorecard._errors import DeclaredLawError, _Declined, _Ours
from reference_impl.bench.scorecard._json import machine_info, write_json
from reference_impl.bench.scorecard._junit import write_junit
from reference_impl.bench.scorecard._plan import (
    DEFAULT_SCENES,
    MAX_SCENES,
    MAX_SPEEDS,
    bench_scene_names,
    plan_cells,
    resolve_scenes,
    scene_damped,
    speed_dependent_law,
)
from reference_impl.bench.scorecard._records import EXIT_INTERNAL, BenchResult
from reference_impl.bench.scorecard._schemes import force_mismatch
from reference_impl.bench.scorecard._textbook import (
    _ORDER_FLOOR,
    VERLET,
    extrapolated_error,
    table_errors,
    textbook_drift,
    textbook_errors,
    textbook_order,
    worst_table_error,
)
from reference_impl.bench.scorecard.metrics import METRICS, MetricResult, SceneContext, SpeedRecord
from reference_impl.bench.scorecard.tolerances import load_tolerances
from reference_impl.bench.worker import Outcome, _one_line, make_executor
from reference_impl.errors import HCVInputError
from reference_impl.exact.api import solve
from reference_impl.scenes import Scene, potential_to_dict
from reference_impl.theory.laws import is_harmonic

__all__ = [
    "DEFAULT_SCENES",
    "EXIT_INTERNAL",
    "MAX_SCENES",
    "MAX_SPEEDS",
    "BenchResult",
    "DeclaredLawError",
    "bench_scene_names",
    "resolve_scenes",
    "run_bench",
]


# Prefix of the reason a declined scene is skipped with (`SceneContext.skipped`), whoever
# declines: a built-in adapter's ``supports`` or a cmd: program's ``unsupported`` answer.
_DECLINED = "declined by the code: "


def _horizon(contact_time: float, contact_time_zero_force: float) -> float | None:
    """The contact time the step and the step budget are taken from (s), or None.

    The overlap end when the body returns to q = 0; else (an overdamped law: it creeps
    back and never gets there, contact time inf) the zero-force end, where the force
    first vanishes and which every damped law reaches in finite time.
    """
    for t in (contact_time, contact_time_zero_force):
        if isinstance(t, (int, float)) and math.isfinite(t) and t > 0:
            return float(t)
    return None


# ----------------------------------------------------------------------------
# one variant on one scene
# ----------------------------------------------------------------------------
class _SceneRun:
    """One adapter variant on one scene: the main run at every speed (with its exact
    reference, textbook baseline and critical step), the speed table, or the sustained run."""

    def __init__(self, executor, index: int, label: str, scene: Scene, tol: dict, scheme=VERLET):
        self.ex, self.index, self.scene, self.tol = executor, index, scene, tol
        self.timeout = float(tol["run"]["timeout"])
        self.scheme = scheme  # the variant's declared scheme (contract item 12)
        self.ctx = SceneContext(
            label, scene.name, scene.kind, scene_damped(scene), speed_dependent_law(scene),
            scheme=scheme,
        )  # fmt: skip
        self.timed_out = ""

    def call(self, method: str, ascene: AdapterScene) -> Outcome:
        """One adapter call; after a first timeout on this scene the rest are not run."""
        if self.timed_out:
            return Outcome(
                False,
                error=f"not run: an earlier run on this scene {self.timed_out}",
                timed_out=True,
            )
        out = self.ex.call(self.index, method, ascene, timeout=self.timeout)
        if out.declined:
            raise _Declined(out.declined)
        if out.timed_out:
            self.timed_out = f"timed out after {self.timeout:g} s"
        return out

    def asked(self, v0: float):
        """Exact solution of the scene's own law and the contact time (s) the step is
        taken from (`_horizon`: the zero-force end's when the law is overdamped): `_Ours`
        when it fails. The harmonic map for the universal law (or none), else the
        general-law reference (`reference_impl.exact.general_law`, ~1e-14), with the
        law's solved parameters."""
        sc = self.scene
        try:
            # the one entry point: the strategy from the law's registry entry
            sol = solve(sc.potential, sc.mass, v0, law=sc.law)
            t_c = _horizon(float(sol.contact_time), float(sol.contact_time_zero_force))
        except Exception as exc:
            raise _Ours(
                f"exact solution of the scene at v0 = {v0:g} m/s failed: {_one_line(exc)}"
            ) from None
        if t_c is None:
            raise _Ours(
                f"exact solution of the scene at v0 = {v0:g} m/s gave no finite contact time "
                f"(overlap end {sol.contact_time!r} s, zero-force end "
                f"{sol.contact_time_zero_force!r} s)"
            )
        return sol, t_c

    def asked_values(self, sol, v0: float) -> dict:
        """What the scene asks at one speed (the delivery metrics' references): the
        restitution at the end the scene names (for a law solved from a restitution at a
        speed, that e at that speed; its exact e at every other speed), the contact time
        (s), the peak force (N), all of the scene's own law solved exactly."""
        end = getattr(self.scene, "restitution_end", "overlap")
        damped = scene_damped(self.scene)
        e = sol.restitution_zero_force if end == "zero-force" and damped else sol.restitution
        sc = self.scene
        if is_harmonic(sc.damping_law):
            law = ImplementedLaw(sc.potential, sc.mass, zeta=float(sc.zeta or 0.0))
        else:
            law = implemented_law_from_table(sc.potential, sc.mass, sc.law.to_dict())
        return {
            "restitution": float(e),
            "end": end,
            "contact_time": float(sol.contact_time),
            "peak_force": exact_peak_force(law, v0, lambda: sol.peak_force),
        }

    def budget(self, dt: float, t_c: float) -> int:
        return int(math.ceil(self.tol["run"]["budget"] * t_c / dt)) + _EXTRA_STEPS

    def impact_speed(self, v0: float) -> SpeedRecord:
        spc = self.tol["run"]["steps_per_contact"]
        sol, t_c = self.asked(v0)
        dt = t_c / spc
        ascene = AdapterScene.from_scene(self.scene, v0, dt, self.budget(dt, t_c))
        asked = self.asked_values(sol, v0)
        # what the user asked, as typed: e at its speed (a speed-dependent law's e at
        # another speed is the law's own target there; FAIL lines name both, issue 40 §3)
        asked["scene_restitution"] = float(ascene.restitution_asked)
        asked["scene_speed"] = ascene.restitution_speed
        rec = SpeedRecord(v0=v0, dt=dt, asked_e=asked["restitution"], asked=asked)
        out = self.call("impact", ascene)
        rec.seconds = out.seconds
        if not out.ok:
            rec.error, rec.stderr = out.error, out.stderr
            return rec
        rigid = rigid_bounce(out.value, v0)
        if rigid is not None:  # no penetration: only the delivered restitution applies
            rec.measured = rigid
            self.ctx.rigid = (
                f"the code reports no penetration at v0 = {v0:g} m/s (a rigid, impulse-based "
                "contact): only the delivered restitution (restitution_asked) is compared"
            )
            return rec
        wrong = check_conventions(out.value, v0)
        if wrong:
            rec.error = f"sign convention: {wrong}"
            return rec
        rec.measured = measure(out.value, v0)
        law = self.call("implemented_law", ascene)
        if not law.ok:
            rec.error = rec.error or f"implemented_law failed: {law.error}"
            rec.stderr = rec.stderr or law.stderr
            return rec
        if not isinstance(law.value, ImplementedLaw):
            rec.error = rec.error or (
                f"malformed output: implemented_law returned {type(law.value).__name__}"
            )
            return rec
        rec.law = law.value
        self.check_law(rec.law, v0)
        try:
            rec.exact = exact_reference(rec.law, v0)
            rec.exact["tensile_sampled"] = exact_tensile_on_samples(
                rec.law,
                v0,
                rec.exact["contact_time"],
                contact_sample_times(out.value, rec.measured),
            )
        except HCVInputError as exc:
            if self.is_scene_law(rec.law):  # the scene's own law, validated: ours
                rec.internal = f"exact solution of the implemented law failed: {_one_line(exc)}"
                return rec
            # the solver refuses the law the code declares (e.g. a power law p = 25,
            # beyond the quadrature's leading exponent 21): its configuration error
            raise DeclaredLawError(
                f"adapter {self.ctx.variant!r} on scene {self.scene.name!r}: "
                f"implemented_law at v0 = {v0:g} m/s is refused by the exact solver: "
                f"{exc} (fix the law the adapter declares)"
            ) from None
        except Exception as exc:  # our solver on the declared law: never the code's failure
            rec.internal = f"exact solution of the implemented law failed: {_one_line(exc)}"
            return rec
        # the reported force against the declared law at the reported states (a units
        # bug, x2 or x1e300, fails implementation naming the force, not the step)
        rec.measured["force_law"] = force_mismatch(out.value, rec.law)
        rec.textbook = textbook_errors(rec.law, ascene, rec.exact, self.scheme)
        rec.dt_crit = dt_crit(self.call, ascene, rec.law, self.tol, self.scheme)
        return rec

    def is_scene_law(self, law: ImplementedLaw) -> bool:
        """The declared law is the scene's own (what was asked), not one the code chose."""

        sc = self.scene
        try:
            same_pot = potential_to_dict(law.potential) == potential_to_dict(sc.potential)
        except Exception:
            return False
        if not (same_pot and law.mass == sc.mass):
            return False
        if is_harmonic(sc.damping_law):
            return law.C is None and float(law.zeta or 0.0) == float(sc.zeta or 0.0)
        # another law of the table: the same law with the same (solved) parameters
        declared = law_of(law.C) if law.C is not None else None
        return declared is not None and declared.to_dict() == sc.law.to_dict()

    def check_law(self, law: ImplementedLaw, v0: float) -> None:
        """`DeclaredLawError` when the code declares a law we cannot accept (not ours)."""
        try:
            check_declared_law(law, v0)
        except HCVInputError as exc:
            raise DeclaredLawError(
                f"adapter {self.ctx.variant!r} on scene {self.scene.name!r}: {exc} "
                "(fix the law the adapter declares)"
            ) from None

    def speed_table(self, rows: list[dict]) -> None:
        """Speed against error at the middle speed; fit the convergence order."""
        ctx, sc = self.ctx, self.scene
        recs = [r for r in ctx.speeds if r.law is not None and r.exact is not None and not r.error]
        if not recs:
            ours = next((r.internal for r in ctx.speeds if r.internal and not r.error), "")
            if ours:
                ctx.order_internal = ours
            else:
                first = next((r for r in ctx.speeds if r.error), None)
                ctx.order_error = "no speed with a successful run and exact reference" + (
                    f" (v0 = {first.v0:g} m/s: {first.error})" if first is not None else ""
                )
            return
        rec = recs[len(recs) // 2]
        try:
            ex = exact_reference(rec.law, rec.v0, timing=True)
        except Exception as exc:  # ours
            ctx.order_internal = f"exact reference of the speed table failed: {_one_line(exc)}"
            return
        rows.append(
            {
                "adapter": ctx.variant,
                "scene": sc.name,
                "v0": rec.v0,
                "method": ex["method"],
                "setting": "reference",
                "steps_per_contact": None,
                "dt": None,
                "seconds": ex["seconds"],
                "err_restitution": 0.0,
                "err_contact_time": 0.0,
                "err_max_penetration": 0.0,
            }
        )
        t_c = _horizon(ex["contact_time"], ex.get("contact_time_zero_force", math.nan))
        if t_c is None:
            ctx.order_internal = (
                "exact reference of the speed table: no finite contact time at either end "
                f"(overlap {ex['contact_time']!r} s, zero force "
                f"{ex.get('contact_time_zero_force', math.nan)!r} s)"
            )
            return
        pts, runs = [], []
        order, why, own_runs = textbook_order(
            rec.law, rec.v0, ex, t_c, self.tol["run"]["speed_error_steps"], self.budget,
            self.scheme,
        )  # fmt: skip
        if why:
            ctx.textbook_order_error = why
        else:
            ctx.textbook_order = order
        for n in self.tol["run"]["speed_error_steps"]:
            dt = t_c / n
            ascene = AdapterScene.from_scene(sc, rec.v0, dt, self.budget(dt, t_c))
            out = self.call("impact", ascene)
            row = {
                "adapter": ctx.variant,
                "scene": sc.name,
                "v0": rec.v0,
                "method": ctx.variant,
                "setting": f"dt = t_c/{n}",
                "steps_per_contact": n,
                "dt": dt,
                "seconds": out.seconds,
            }
            if not out.ok:
                row["failure"] = out.error
                rows.append(row)
                continue
            meas = measure(out.value, rec.v0)
            errs = table_errors(meas, ex)
            row.update(errs)
            rows.append(row)
            runs.append((n, meas))
            worst = worst_table_error(errs)
            if math.isfinite(worst) and worst > _ORDER_FLOOR:
                pts.append((dt, worst))
        mine = [
            r
            for r in rows
            if r["adapter"] == ctx.variant
            and r["scene"] == sc.name
            and r["steps_per_contact"] is not None
        ]
        failed = [r for r in mine if "failure" in r]
        if not why and not self.scheme.variable:
            self.extrapolate(runs, own_runs, ex, order)
        if len(pts) >= 3:
            x, y = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
            ctx.order = float(np.polyfit(x, y, 1)[0])
        elif not failed:
            ctx.order = math.inf  # errors at round-off: nothing left to converge
        else:
            ctx.order_error = (
                f"{len(failed)} of {len(mine)} runs of the speed-against-error "
                f"table failed: {failed[0]['failure']}"
            )

    def extrapolate(self, runs: list, own_runs: list, ex: dict, own_order: float) -> None:
        """The study's extrapolated answer against the exact one (`extrapolated_error`).

        Both the code's runs and the declared scheme's own runs on the exact law are
        extrapolated with one order: the smaller of the scheme's measured order on this
        table and the declared order (what a correct code of the scheme shows here).
        The scheme's own residual is the allowance (the next order's term).
        """
        p = min(own_order, self.scheme.order) if own_order > 0 else self.scheme.order
        err, which = extrapolated_error(runs, ex, p)
        own, _ = extrapolated_error(own_runs, ex, p)
        self.ctx.extrapolated = {
            "error": err, "quantity": which, "allowance": own, "order": p,
            "steps": sorted(n for n, _ in runs)[-2:],
        }  # fmt: skip

    def sustained(self) -> None:
        ctx, sc = self.ctx, self.scene
        v0 = sc.velocities[0]
        t_c = self.asked(v0)[1]
        dt = t_c / self.tol["run"]["steps_per_contact"]
        n = int(self.tol["run"]["sustained_steps"])
        ascene = AdapterScene.from_scene(sc, v0, dt, n)
        out = self.call("sustained", ascene)
        if not out.ok:
            ctx.sustained = {"error": out.error, "stderr": out.stderr}
            return
        tr: Trajectory = out.value
        qp = np.clip(tr.q, 0.0, None)
        try:
            with np.errstate(all="ignore"):
                U = sc.potential._U(qp)
        except Exception as exc:  # ours: U outside the domain the potential covers
            raise _Ours(f"energy of the sustained run: {_one_line(exc)}") from None
        E = 0.5 * sc.mass * tr.v**2 + U
        E0 = 0.5 * sc.mass * v0 * v0
        drift = float(np.max(np.abs(E / E0 - 1.0))) if np.all(np.isfinite(E)) else math.inf
        impacts = int(np.sum((tr.q[1:] > 0) & (tr.q[:-1] <= 0)))
        ctx.sustained = {
            "drift": drift,
            "textbook_drift": textbook_drift(sc, v0, dt, n),
            "steps": int(tr.t.size - 1),
            "impacts": impacts,
            "dt": dt,
            "seconds": out.seconds,
        }

    def run(self, rows: list[dict]) -> SceneContext:
        ctx = self.ctx
        try:
            if ctx.kind == "two-walls":
                self.sustained()
                return ctx
            for v0 in self.scene.velocities:
                ctx.speeds.append(self.impact_speed(v0))
            self.speed_table(rows)
        except _Declined as exc:
            ctx.skipped, ctx.speeds, ctx.sustained = f"{_DECLINED}{exc}", [], None
        except _Ours as exc:
            ctx.internal = str(exc)
        return ctx


# ----------------------------------------------------------------------------
# the entry point
# ----------------------------------------------------------------------------
def run_bench(
    adapter_spec,
    scenes=None,
    tolerances=None,
    json_path=None,
    junit_path=None,
    progress: Callable[[float, float], None] | None = None,
) -> BenchResult:
    """Benchmark one adapter on scenes; the function ``hcv bench`` calls.

    Parameters
    ----------
    adapter_spec : str or ContactAdapter
        Registered name, ``package.module:Class``, ``cmd:COMMAND`` (optionally
        with ``[key=value,...]``), or an adapter instance (run in-process).
    scenes : sequence of str or Scene, optional
        Scene names (embedded or bench scenes) or TOML paths; default
        `DEFAULT_SCENES`.
    tolerances : str, path or dict, optional
        User tolerances overriding the defaults (`load_tolerances`).
    json_path, junit_path : path, optional
        Where to write the JSON report (rewritten after every scene) and JUnit XML.
    progress : callable, optional
        ``progress(done, total)`` after every adapter variant x scene.

    Returns
    -------
    BenchResult
        On Ctrl-C the results computed so far, with ``interrupted`` set (files written).

    Raises
    ------
    HCVInputError
        Usage or configuration errors (unknown adapter, bad scene, bad tolerances). A
        variant declining scenes (all of them, even) is no error: they are skipped with
        the reason. Adapter *run* failures are never raised: they are failed metrics.
    """

    tol = load_tolerances(tolerances)
    scene_list = resolve_scenes(scenes)
    executor = make_executor(adapter_spec, startup_timeout=tol["run"]["startup_timeout"])
    spec = adapter_spec if isinstance(adapter_spec, str) else repr(adapter_spec)
    variants = executor.variants
    labels = [v.label for v in variants]
    if len(set(labels)) != len(labels):
        executor.close()
        raise HCVInputError(
            f"adapter {adapter_spec!r}: variants must have distinct labels, got {labels}"
        )
    try:  # each variant's declared scheme, checked before anything runs
        schemes = [scheme_of(var) for var in variants]
    except HCVInputError:
        executor.close()
        raise
    for var in variants:  # in-process adapters with their own timeout take the run's
        if getattr(var, "timeout_given", True) is False:
            var.timeout = float(tol["run"]["timeout"])
    # a variant that declines a scene (``supports`` here, or an ``unsupported`` answer of a
    # cmd: program during the run) is one rule: the scene is skipped with its reason, and
    # a run that declined everything measured nothing (exit 1 with --gate, 0 without):
    # valid input, never a usage error
    plan = plan_cells(variants, scene_list)
    result = BenchResult(
        adapter=spec,
        scenes=[s.name for s in scene_list],
        tolerances=tol,
        machine=machine_info(),
        started=time.time(),
    )
    t0 = time.perf_counter()
    try:
        for i, var in enumerate(variants):
            desc = executor.call(i, "describe", timeout=tol["run"]["timeout"])
            result.variants.append(
                desc.value
                if desc.ok and isinstance(desc.value, dict)
                else {"label": var.label, "describe_error": desc.error}
            )
        total = float(len(plan))
        if progress is not None:
            progress(0.0, total)
        for done, (i, var, sc, reason) in enumerate(plan, start=1):
            reason = reason or offset_refusal(var)
            if reason:
                ctx = SceneContext(
                    var.label,
                    sc.name,
                    sc.kind,
                    scene_damped(sc),
                    speed_dependent_law(sc),
                    skipped=f"{_DECLINED}{reason}",
                )
                result.metrics.extend(
                    MetricResult(
                        var.label,
                        sc.name,
                        m.name,
                        "skip",
                        explanation=f"{_DECLINED}{reason}",
                        description=m.description,
                    )
                    for m in METRICS
                )
            else:
                ctx = _SceneRun(executor, i, var.label, sc, tol, schemes[i]).run(result.speed_error)
                result.metrics.extend(m.evaluate(ctx, tol) for m in METRICS)
            result.contexts.append(ctx)
            result.seconds = time.perf_counter() - t0
            if json_path is not None:
                write_json(result, json_path)
            if progress is not None:
                progress(float(done), total)
    except KeyboardInterrupt:
        result.interrupted = True
    finally:
        executor.close()
        result.seconds = time.perf_counter() - t0
        if json_path is not None:
            write_json(result, json_path)
        if junit_path is not None:
            write_junit(result, junit_path)
    return result
