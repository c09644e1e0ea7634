"""The benchmark run loop: scenes through an adapter and through the exact solution.

For every adapter variant and scene, and every impact speed of the scene:

1. the main run at dt = (exact contact time) / steps_per_contact;
2. the law the code implements (``implemented_law``) and its exact solution;
3. a critical-step search on the code: increasing dt until the rebound energy
   exceeds (1 + gain_tol) E_0, the run blows up or fails, then bisection;

then, at the middle speed, the speed-against-error table (several dt, wall time
of each run, errors against the exact solution), and for two-walls scenes one
long elastic run (energy drift). The metrics of `reference_impl.bench.metrics`
are evaluated on the records.

Isolation: every adapter call goes through an executor
(`reference_impl.bench.worker`); a crash, hang or malformed output fails that
run only, with its one-line reason and stderr, and the loop goes on. Results are
kept in the `BenchResult` as they come; with ``json_path`` the JSON file is
rewritten after every scene (and on interruption), so nothing computed is lost.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from reference_impl.adapters.base import AdapterScene, ImplementedLaw, Trajectory
from reference_impl.bench.measure import (
    check_conventions,
    check_declared_law,
    contact_sample_times,
    exact_reference,
    exact_tensile_on_samples,
    measure,
)
from reference_impl.bench.metrics import METRICS, MetricResult, SceneContext, SpeedRecord
from reference_impl.bench.tolerances import load_tolerances
from reference_impl.bench.worker import Outcome, _one_line, make_executor
from reference_impl.errors import HCVInputError
from reference_impl.exact.solve import solve_impact
from reference_impl.scenes import Scene, load_scene
from reference_impl.stability.bound import dt_safe as _dt_safe

__all__ = ["DEFAULT_SCENES", "BenchResult", "bench_scene_names", "resolve_scenes", "run_bench"]

# Scenes run when none are given (all in the one catalogue, `hcv scenes`).
DEFAULT_SCENES = ("hertz", "hertz-damped", "hooke-damped", "hertz-walls")
# Upper bounds checked before any work: each speed costs a main run, a critical-step
# search (~20 runs) and each scene a speed table (~6 runs); 32 speeds x 64 scenes is
# already ~40,000 adapter runs.
MAX_SCENES = 64
# Gate exit status when no metric failed but the suite's own reference could not decide one.
EXIT_INTERNAL = 3
MAX_SPEEDS = 32
# Critical-step scan, in units of dt_safe, before bisection.
_DT_SCAN = (0.5, 0.75, 1.0, 1.25, 1.5, 2.0, 2.5, 3.0, 4.0, 6.0, 8.0)
_DT_LOW = (0.25, 0.125, 0.0625)
# Step budget of a critical-step run: this many straight-line times q_max / v0 (as dtcrit).
_DTCRIT_BUDGET = 40.0
_EXTRA_STEPS = 64
# Relative errors below this are round-off: left out of the convergence fit.
_ORDER_FLOOR = 1e-13


def bench_scene_names() -> list[str]:
    """Names of the benchmark's default scenes (embedded scenes, listed by ``hcv scenes``)."""
    return list(DEFAULT_SCENES)


def resolve_scenes(scenes: Sequence[str | Scene] | None) -> list[Scene]:
    """Scenes from names (embedded scenes), TOML paths or Scene objects.

    Raises
    ------
    HCVInputError
        No scene, more than `MAX_SCENES` scenes or `MAX_SPEEDS` speeds in one,
        a kind the bench does not run, zeta >= 1, or repeated names.
    """
    items = list(DEFAULT_SCENES if scenes is None else scenes)
    if not items:
        raise HCVInputError("no scenes given")
    if len(items) > MAX_SCENES:
        raise HCVInputError(f"{len(items)} scenes given; hcv bench runs at most {MAX_SCENES}")
    out = []
    for s in items:
        sc = s if isinstance(s, Scene) else load_scene(s)
        if sc.kind not in ("impact", "two-walls"):
            raise HCVInputError(
                f"scene {sc.name!r}: hcv bench runs impact and two-walls scenes, not {sc.kind!r}"
            )
        if len(sc.velocities) > MAX_SPEEDS:
            raise HCVInputError(
                f"scene {sc.name!r} has {len(sc.velocities)} speeds; hcv bench "
                f"runs at most {MAX_SPEEDS} per scene"
            )
        if sc.damping_law == "universal" and (sc.zeta or 0.0) >= 1.0:
            raise HCVInputError(
                f"scene {sc.name!r}: hcv bench needs damping zeta < 1, got "
                f"{sc.zeta!r} (the restitution asked, exp(-pi zeta / sqrt(1 - "
                "zeta^2)), is defined for zeta < 1 only)"
            )
        out.append(sc)
    names = [s.name for s in out]
    dup = {n for n in names if names.count(n) > 1}
    if dup:
        raise HCVInputError(f"scene names must be unique, {', '.join(sorted(dup))} repeats")
    return out


@dataclass
class BenchResult:
    """Everything one `run_bench` call measured (see `reference_impl.bench.report` for output).

    Attributes
    ----------
    adapter : str
        The adapter spec.
    variants : list of dict
        ``describe()`` of each variant.
    scenes : list of str
        Scene names, in run order.
    metrics : list of MetricResult
        The scorecard: one entry per variant, scene and metric.
    contexts : list of SceneContext
        Raw per-speed records (runs, exact references, critical steps).
    speed_error : list of dict
        Speed-against-error rows (workprecision style).
    tolerances : dict
        The tolerances used.
    machine : dict
        Machine and commit information.
    interrupted : bool
        The run was interrupted; the results are those computed so far.
    """

    adapter: str
    variants: list[dict] = field(default_factory=list)
    scenes: list[str] = field(default_factory=list)
    metrics: list[MetricResult] = field(default_factory=list)
    contexts: list[SceneContext] = field(default_factory=list)
    speed_error: list[dict] = field(default_factory=list)
    tolerances: dict = field(default_factory=dict)
    machine: dict = field(default_factory=dict)
    started: float = 0.0
    seconds: float = 0.0
    interrupted: bool = False

    def counts(self) -> dict[str, int]:
        """Metrics per status: pass, fail, skip, and error (our reference failed)."""
        c = {"pass": 0, "fail": 0, "skip": 0, "error": 0}
        for m in self.metrics:
            c[m.status] += 1
        return c

    @property
    def failures(self) -> list[MetricResult]:
        return [m for m in self.metrics if m.status == "fail"]

    @property
    def internal_errors(self) -> list[MetricResult]:
        """Metrics not decided because the suite's own reference failed (never the code's fault)."""
        return [m for m in self.metrics if m.status == "error"]

    @property
    def measured_nothing(self) -> bool:
        """No metric was decided (every one skipped: declined scenes, no reference)."""
        return not any(m.status in ("pass", "fail", "error") for m in self.metrics)

    def exit_status(self, gate: bool) -> int:
        """0; with ``gate`` 1 when a metric failed, nothing was measured (every metric
        skipped: a gate that measured nothing does not pass) or the run was interrupted,
        else `EXIT_INTERNAL` when the reference failed on a metric, else 0."""
        if not gate:
            return 0
        if self.failures or self.interrupted or self.measured_nothing:
            return 1
        return EXIT_INTERNAL if self.internal_errors else 0

    def to_dict(self) -> dict:
        from reference_impl.bench.report import result_to_dict

        return result_to_dict(self)


# ----------------------------------------------------------------------------
# one variant on one scene
# ----------------------------------------------------------------------------
class _Declined(Exception):
    """The code declined the scene at run time ({"unsupported": reason}): a skip."""


class _Ours(Exception):
    """The suite's own reference failed: an internal error, never the code's failure."""


class DeclaredLawError(HCVInputError):
    """A code declared an implemented law no reference can be computed for (its
    configuration error): ``hcv bench`` stops with exit status 2, naming the field."""


class _SceneRun:
    def __init__(self, executor, index: int, label: str, scene: Scene, tol: dict):
        self.ex, self.index, self.scene, self.tol = executor, index, scene, tol
        self.timeout = float(tol["run"]["timeout"])
        damped = scene.damping_law == "universal" and bool(scene.zeta)
        self.ctx = SceneContext(label, scene.name, scene.kind, damped)
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
        """Exact solution of the scene's own law (ours): `_Ours` when it fails."""
        try:
            sol = solve_impact(self.scene.potential, self.scene.mass, v0, self.scene.zeta or 0.0)
            t_c = float(sol.contact_time)
        except Exception as exc:
            raise _Ours(
                f"exact solution of the scene at v0 = {v0:g} m/s failed: {_one_line(exc)}"
            ) from None
        if not (math.isfinite(t_c) and t_c > 0):
            raise _Ours(
                f"exact solution of the scene at v0 = {v0:g} m/s gave the contact time {t_c!r}"
            )
        return sol

    def budget(self, dt: float, t_c: float) -> int:
        return int(math.ceil(self.tol["run"]["budget"] * t_c / dt)) + _EXTRA_STEPS

    def impact_speed(self, v0: float) -> SpeedRecord:
        spc = self.tol["run"]["steps_per_contact"]
        t_c = self.asked(v0).contact_time
        dt = t_c / spc
        ascene = AdapterScene.from_scene(self.scene, v0, dt, self.budget(dt, t_c))
        rec = SpeedRecord(v0=v0, dt=dt, asked_e=ascene.restitution)
        out = self.call("impact", ascene)
        rec.seconds = out.seconds
        if not out.ok:
            rec.error, rec.stderr = out.error, out.stderr
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
        rec.textbook = self.textbook(rec.law, ascene, rec.exact)
        rec.dt_crit = self.dt_crit(ascene, rec.law)
        return rec

    def is_scene_law(self, law: ImplementedLaw) -> bool:
        """The declared law is the scene's own (what was asked), not one the code chose."""
        from reference_impl.scenes import potential_to_dict

        try:
            same_pot = potential_to_dict(law.potential) == potential_to_dict(self.scene.potential)
        except Exception:
            return False
        return (
            same_pot
            and law.C is None
            and law.mass == self.scene.mass
            and float(law.zeta or 0.0) == float(self.scene.zeta or 0.0)
        )

    def check_law(self, law: ImplementedLaw, v0: float) -> None:
        """`DeclaredLawError` when the code declares a law we cannot accept (not ours)."""
        try:
            check_declared_law(law, v0)
        except HCVInputError as exc:
            raise DeclaredLawError(
                f"adapter {self.ctx.variant!r} on scene {self.scene.name!r}: {exc} "
                "(fix the law the adapter declares)"
            ) from None

    def textbook(self, law: ImplementedLaw, ascene: AdapterScene, exact: dict) -> dict:
        """Errors of textbook velocity Verlet with the implemented law, at the run's own step.

        The error a correct code makes at the step the suite gives it (tolerances.toml,
        [allowance]): relative errors of restitution, contact time and max penetration
        against ``exact``, |E_out/E_in - 1|, and the tensile peak against the exact law
        sampled at Verlet's own instants. ``{"error": reason}`` when the reference
        Verlet cannot run the declared damping (a callable C(q)); ``{"internal": ...}``
        when it failed (ours).
        """
        from reference_impl.adapters.reference import law_trajectory

        v0 = ascene.v0
        try:
            t, q, v, f = law_trajectory(law, v0, ascene.dt, ascene.n_steps)
        except TypeError as exc:  # a damping the reference Verlet cannot run
            return {"error": f"textbook Verlet cannot run the declared law ({_one_line(exc)})"}
        except Exception as exc:  # ours
            return {
                "internal": f"textbook Verlet with the implemented law failed: {_one_line(exc)}"
            }
        tr = Trajectory(t, q, v, f)
        m = measure(tr, v0)
        out: dict = {"restitution_value": m.get("restitution", math.nan)}
        for k in ("restitution", "contact_time", "max_penetration"):
            got, want = m.get(k, math.nan), exact[k]
            out[k] = abs(got - want) / abs(want) if want else math.inf
        out["energy_ratio"] = abs(m.get("energy_ratio", math.nan) - 1.0)
        try:
            ref = exact_tensile_on_samples(
                law, v0, exact["contact_time"], contact_sample_times(tr, m)
            )
        except Exception as exc:  # ours
            return {
                "internal": f"exact tensile peak on textbook Verlet's samples: {_one_line(exc)}"
            }
        out["tensile"] = abs(m.get("tensile", math.nan) - ref)
        for k, x in list(out.items()):
            if not math.isfinite(x):
                # a correct scheme at this step did not measure it: no allowance can be derived
                return {"internal": f"textbook Verlet at dt = {ascene.dt:.4g} s gave no finite {k}"}
        return out

    def _stable(self, ascene: AdapterScene, dt: float, q_max: float) -> tuple[bool, str]:
        v0 = ascene.v0
        n = int(math.ceil(_DTCRIT_BUDGET * q_max / (v0 * dt))) + _EXTRA_STEPS
        out = self.call("impact", ascene.replace(dt=dt, n_steps=n))
        if not out.ok:
            return False, f"run failed: {out.error}"
        return self._verdict(measure(out.value, v0))

    def _verdict(self, m: dict) -> tuple[bool, str]:
        if not m.get("finite", True):
            return False, "blew up (non-finite state)"
        if not m["separated"]:
            return False, m.get("reason", "did not separate")
        gain = m["energy_ratio"]
        if gain > 1.0 + self.tol["dt_crit"]["gain_tol"]:
            return False, f"rebound energy {gain:.4g} E_0"
        return True, ""

    def _verlet_stable(
        self, law: ImplementedLaw, v0: float, dt: float, q_max: float
    ) -> tuple[bool, str]:
        from reference_impl.adapters.reference import law_trajectory

        n = int(math.ceil(_DTCRIT_BUDGET * q_max / (v0 * dt))) + _EXTRA_STEPS
        t, q, v, f = law_trajectory(law, v0, dt, n)
        return self._verdict(measure(Trajectory(t, q, v, f), v0))

    def dt_crit(self, ascene: AdapterScene, law: ImplementedLaw) -> dict:
        """Critical step on the code and on textbook Verlet with the same law, over dt_safe."""
        pot, m, v0 = law.potential, law.mass, ascene.v0
        try:
            safe = _dt_safe(pot, m, v0)
            q_max = pot.turning_point(0.5 * m * v0 * v0)
        except Exception as exc:  # ours, not the code's
            return {"internal": f"dt_safe of the implemented law failed: {_one_line(exc)}"}
        ref = safe.dt_safe if safe.dt_safe > 0 else safe.dt_shortcut
        res = self.tol["dt_crit"]["resolution"]
        out = {"dt_safe": ref}
        code = _search(lambda f: self._stable(ascene, f * ref, q_max), res)
        out.update(
            dt_crit=code["ratio"] * ref,
            ratio=code["ratio"],
            reason=code["reason"],
            runs=code["runs"],
        )
        try:
            verlet = _search(lambda f: self._verlet_stable(law, v0, f * ref, q_max), res)
            out.update(verlet_dt_crit=verlet["ratio"] * ref, verlet_ratio=verlet["ratio"])
        except TypeError as exc:  # a damping the reference Verlet cannot run: no baseline
            out["verlet_error"] = f"textbook Verlet cannot run the declared law ({_one_line(exc)})"
        except Exception as exc:  # ours, not the code's
            out["internal"] = f"textbook Verlet with the implemented law failed: {_one_line(exc)}"
        return out

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
        t_c = ex["contact_time"]
        pts = []
        self.textbook_order(rec, ex, t_c)
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
            errs = {}
            for k in ("restitution", "contact_time", "max_penetration"):
                got, want = meas.get(k, math.nan), ex[k]
                errs[f"err_{k}"] = abs(got - want) / abs(want) if math.isfinite(got) else math.inf
            row.update(errs)
            rows.append(row)
            worst = max(errs.values())
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

    def textbook_order(self, rec: SpeedRecord, ex: dict, t_c: float) -> None:
        """Convergence order of textbook Verlet with the implemented law on the same table.

        The order a correct code shows on this scene at these steps (velocity Verlet is
        second order, first order once a velocity-dependent dashpot is evaluated
        explicitly; heavily damped scenes are pre-asymptotic at 25-800 steps). Sets
        ``ctx.textbook_order``, or ``ctx.textbook_order_error`` when it cannot be run.
        """
        from reference_impl.adapters.reference import law_trajectory

        pts = []
        for n in self.tol["run"]["speed_error_steps"]:
            dt = t_c / n
            try:
                t, q, v, f = law_trajectory(rec.law, rec.v0, dt, self.budget(dt, t_c))
            except TypeError as exc:
                self.ctx.textbook_order_error = (
                    f"textbook Verlet cannot run the declared law ({_one_line(exc)})"
                )
                return
            meas = measure(Trajectory(t, q, v, f), rec.v0)
            errs = [
                abs(meas.get(k, math.nan) - ex[k]) / abs(ex[k])
                for k in ("restitution", "contact_time", "max_penetration")
            ]
            worst = max(errs)
            if math.isfinite(worst) and worst > _ORDER_FLOOR:
                pts.append((dt, worst))
        if len(pts) >= 3:
            x, y = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
            self.ctx.textbook_order = float(np.polyfit(x, y, 1)[0])
        else:
            self.ctx.textbook_order = math.inf  # at round-off: nothing left to converge

    def sustained(self) -> None:
        ctx, sc = self.ctx, self.scene
        v0 = sc.velocities[0]
        t_c = self.asked(v0).contact_time
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
            "textbook_drift": self.textbook_drift(v0, dt, n),
            "steps": int(tr.t.size - 1),
            "impacts": impacts,
            "dt": dt,
            "seconds": out.seconds,
        }

    def textbook_drift(self, v0: float, dt: float, n: int) -> float:
        """Energy drift of textbook Verlet on the same two-walls run (the allowance's scale)."""
        from reference_impl.adapters.reference import verlet_trajectory

        sc = self.scene
        try:
            t, q, v, f = verlet_trajectory(
                sc.potential,
                sc.mass,
                v0,
                dt,
                n,
                zeta=sc.zeta or 0.0,
                kind="two-walls",
                gap=float(sc.gap or 0.0),
            )
            with np.errstate(all="ignore"):
                E = 0.5 * sc.mass * v**2 + sc.potential._U(np.clip(q, 0.0, None))
        except Exception as exc:  # ours
            raise _Ours(f"textbook Verlet on the two-walls scene: {_one_line(exc)}") from None
        E0 = 0.5 * sc.mass * v0 * v0
        return float(np.max(np.abs(E / E0 - 1.0))) if np.all(np.isfinite(E)) else math.inf

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
            ctx.skipped, ctx.speeds, ctx.sustained = f"declined by the code: {exc}", [], None
        except _Ours as exc:
            ctx.internal = str(exc)
        return ctx


def _search(stable: Callable[[float], tuple[bool, str]], resolution: float) -> dict:
    """Smallest unstable step, in units of dt_safe: scan `_DT_SCAN`, then bisect.

    Returns ``ratio`` (inf when every scanned step was stable), the reason of the
    deciding failure and the number of runs.
    """
    tried: dict[float, tuple[bool, str]] = {}

    def ok(f: float) -> bool:
        if f not in tried:
            tried[f] = stable(f)
        return tried[f][0]

    first_bad = next((f for f in _DT_SCAN if not ok(f)), None)
    if first_bad is None:
        return {
            "ratio": math.inf,
            "reason": f"stable up to {_DT_SCAN[-1]:g} dt_safe",
            "runs": len(tried),
        }
    below = [f for f in _DT_SCAN if f < first_bad]
    lo = below[-1] if below else 0.0
    if lo == 0.0:
        for f in _DT_LOW:
            if ok(f):
                lo = f
                break
            first_bad = f
    hi = first_bad
    while lo > 0 and hi - lo > resolution:
        mid = 0.5 * (lo + hi)
        if ok(mid):
            lo = mid
        else:
            hi = mid
    return {"ratio": hi, "stable_ratio": lo, "reason": tried[hi][1], "runs": len(tried)}


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
        Usage or configuration errors (unknown adapter, bad scene, bad tolerances,
        an adapter that supports none of the scenes). Adapter *run* failures are
        never raised: they are failed metrics.
    """
    from reference_impl.bench.report import machine_info, write_json, write_junit

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
    for var in variants:  # in-process adapters with their own timeout take the run's
        if getattr(var, "timeout_given", True) is False:
            var.timeout = float(tol["run"]["timeout"])
    plan = []
    for i, var in enumerate(variants):
        for sc in scene_list:
            probe = AdapterScene.from_scene(sc, sc.velocities[0], 1.0, 1)
            plan.append((i, var, sc, var.supports(probe)))
    if all(reason for *_, reason in plan):
        executor.close()
        reasons = sorted({reason for *_, reason in plan})
        raise HCVInputError(
            f"adapter {spec!r} supports none of the scenes "
            f"({', '.join(s.name for s in scene_list)}): {reasons[0]}"
        )
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
            if reason:
                ctx = SceneContext(var.label, sc.name, sc.kind, bool(sc.zeta), skipped=reason)
                result.metrics.extend(
                    MetricResult(
                        var.label,
                        sc.name,
                        m.name,
                        "skip",
                        explanation=f"scene not supported: {reason}",
                        description=m.description,
                    )
                    for m in METRICS
                )
            else:
                ctx = _SceneRun(executor, i, var.label, sc, tol).run(result.speed_error)
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
