"""``hcv calibrate``: the value of a code's own option that delivers a target, at a resolution.

    hcv calibrate ADAPTER --scene SCENE --target restitution=0.5 --param KEY
                  [--end overlap|zero-force] [--steps-per-contact N] [--v0 V]
                  [--range LO HI] [--isolate] [--json]

For one impact of SCENE at speed V (default: the scene's middle speed), run at
dt = t_c / N (t_c the exact contact time of the scene as asked, N = 200 by
default, as ``hcv bench``), this finds by a bracketed root search (a scan of the
range, then `scipy.optimize.brentq`) the value of the adapter option KEY (a
constructor argument, e.g. ``mujoco``'s ``dampratio`` or ``damping``, LAMMPS'
``eta_n0``, Kratos' ``gamma``) for which the code's measured restitution at the
chosen end equals the target:

* ``overlap``: -v / v0 at the first sample with q <= 0 (what the scene's
  ``restitution`` means);
* ``zero-force``: -v / v0 where the total force first vanishes after the deepest
  overlap (a code that never lets the force pull delivers this one at q = 0 too).

It prints the value, the achieved restitution, and at that value the code's
contact time, maximum penetration and both restitutions with their errors against
the exact solution of the law the code declares (its integration error) and
against the scene as asked (what the user gets). A target outside what the option
delivers over its range is said so, with the range of values it delivers there
(exit status 1). Bad input: one line, exit status 2.

Evaluations run in-process (``--isolate``: each in a worker process, as ``hcv
bench`` runs isolated adapters, with the per-run timeout). ``calibrate`` is also a task of ``hcv sweep``
(``task = "calibrate:ADAPTER"``, see `reference_impl.sweep`).
"""

from __future__ import annotations

import inspect
import math
from dataclasses import asdict, dataclass, field

import numpy as np
from scipy.optimize import brentq

from reference_impl.adapters.base import AdapterScene, ImplementedLaw
from reference_impl.adapters.registry import get_adapter, parse_spec, resolve_class
from reference_impl.bench.measure import exact_reference, measure
from reference_impl.bench.worker import make_executor
from reference_impl.errors import HCVInputError
from reference_impl.exact.solve import solve_impact
from reference_impl.scenes import Scene, load_scene
from reference_impl.theory.damping import RESTITUTION_ENDS

__all__ = [
    "ENDS",
    "CalibrationResult",
    "calibrate",
    "delivered",
    "spec_with_options",
]

ENDS = RESTITUTION_ENDS
QUANTITIES = ("restitution",)
EXIT_OK, EXIT_UNREACHABLE, EXIT_USAGE = 0, 1, 2
# Points of the bracketing scan over the range (log-spaced when the range is positive):
# enough to find the sign change of a monotone response and to report its span.
_SCAN_POINTS = 9
# Root tolerance on the option, relative: below the measured restitution's own
# step-to-step resolution at any N the bench uses.
_XRTOL = 1e-9
_MAXITER = 100
# Bounds on user-controlled sizes.
_MAX_STEPS_PER_CONTACT = 100_000
_MIN_STEPS_PER_CONTACT = 2
# Step budget of a run: this many contact times plus a margin (as hcv bench).
_BUDGET, _EXTRA_STEPS = 4.0, 64


@dataclass
class CalibrationResult:
    """Outcome of one calibration (`calibrate`); every restitution says its end.

    Attributes
    ----------
    adapter, param, end, quantity : str
        The adapter spec, the option searched, the end of contact, the quantity.
    target : float
        The value asked of the quantity.
    steps_per_contact : int
        N: dt = t_c / N, t_c the exact contact time of the scene as asked (s).
    v0, dt : float
        Impact speed (m/s) and time step (s).
    range : tuple of float
        The option's search range.
    found : bool
        A value delivering the target was found.
    value : float
        The option's value (NaN when not found).
    achieved : float
        The quantity the code delivers at ``value``.
    delivered : tuple of float
        Smallest and largest value of the quantity seen over the range.
    metrics : dict
        At ``value``: measured quantities, exact values of the declared law and of
        the scene as asked, relative errors (see `_metrics`).
    evaluations : int
        Adapter runs made.
    message : str
        One line: the answer, or why the target is out of reach.
    """

    adapter: str
    scene: str
    param: str
    end: str
    quantity: str
    target: float
    steps_per_contact: int
    v0: float
    dt: float
    range: tuple
    found: bool = False
    value: float = math.nan
    achieved: float = math.nan
    delivered: tuple = (math.nan, math.nan)
    metrics: dict = field(default_factory=dict)
    evaluations: int = 0
    message: str = ""

    def to_dict(self) -> dict:
        d = asdict(self)
        d["range"], d["delivered"] = list(self.range), list(self.delivered)
        return d


def spec_with_options(spec: str, options: dict) -> str:
    """``spec`` with constructor arguments added or replaced (``NAME[k=v,...]``, ``cmd[...]:``)."""
    if not options:
        return spec
    target, kwargs = parse_spec(spec)
    for key, val in options.items():
        if not isinstance(key, str) or not key.isidentifier():
            raise HCVInputError(f"adapter option {key!r} is not a name")
        kwargs[key] = val
    bad = [v for v in kwargs.values() if isinstance(v, str) and any(c in v for c in ",[]=")]
    if bad:
        raise HCVInputError(f"adapter option value {bad[0]!r} may not contain , [ ] =")

    def text(v) -> str:
        if isinstance(v, bool):
            return "true" if v else "false"
        if v is None:
            return "none"
        return repr(float(v)) if isinstance(v, float) else str(v)

    if target == "subprocess":
        command = kwargs.pop("command")
        args = ",".join(f"{k}={text(v)}" for k, v in kwargs.items())
        return f"cmd[{args}]:{command}"
    return f"{target}[{','.join(f'{k}={text(v)}' for k, v in kwargs.items())}]"


def check_option(spec: str, param: str) -> type:
    """The adapter class of ``spec``; HCVInputError when it has no constructor option ``param``."""
    target, _ = parse_spec(spec)
    cls = resolve_class(target)
    try:
        params = inspect.signature(cls).parameters
    except (TypeError, ValueError):
        return cls
    names = [n for n, p in params.items() if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)]
    if param not in names and not any(p.kind == p.VAR_KEYWORD for p in params.values()):
        raise HCVInputError(
            f"adapter {target!r} has no option {param!r}; its options: {', '.join(names)}"
        )
    return cls


def _range(cls: type, param: str, scene, given) -> tuple[float, float]:
    if given is not None:
        lo, hi = (float(x) for x in given)
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise HCVInputError(f"--range {given[0]!r} {given[1]!r}: need finite LO < HI")
        return lo, hi
    fn = getattr(cls, "calibration_range", None)
    rng = fn(param, scene) if fn is not None else None
    if rng is None:
        raise HCVInputError(
            f"no default range for option {param!r} of {cls.__name__}; give --range LO HI"
        )
    return float(rng[0]), float(rng[1])


def _run(spec: str, ascene: AdapterScene, timeout: float, isolate: bool):
    """One run: (trajectory, implemented law, error); HCVInputError when declined."""

    executor = make_executor(spec, isolate=isolate)
    try:
        if len(executor.variants) != 1:
            raise HCVInputError(
                f"adapter {spec!r} has {len(executor.variants)} variants; configure one "
                f"(e.g. {executor.variants[0].label})"
            )
        reason = executor.variants[0].supports(ascene)
        if reason:
            raise HCVInputError(f"adapter {spec!r} declines the scene: {reason}")
        out = executor.call(0, "impact", ascene, timeout=timeout)
        if out.declined:
            raise HCVInputError(f"adapter {spec!r} declines the scene: {out.declined}")
        if not out.ok:
            return None, None, out.error
        law = executor.call(0, "implemented_law", ascene, timeout=timeout)
        return out.value, (law.value if law.ok else None), law.error if not law.ok else ""
    finally:
        executor.close()


def _quantity(meas: dict, end: str) -> float:
    key = "restitution" if end == "overlap" else "restitution_zero_force"
    val = meas.get(key)
    return float(val) if isinstance(val, float) and math.isfinite(val) else math.nan


def _metrics(tr, law: ImplementedLaw | None, scene, v0: float) -> dict:
    """Measured quantities at the calibrated value, against the declared law and the scene."""

    meas = measure(tr, v0)
    keys = ("restitution", "restitution_zero_force", "contact_time", "max_penetration")
    out: dict = {"measured": {k: meas.get(k) for k in keys}}
    if law is not None:
        ex = exact_reference(law, v0)
        # clipped laws: exact_reference's restitution is already the zero-force end
        ex_q0 = ex["restitution"]
        out["declared_law"] = {
            "description": law.description,
            "restitution": ex_q0,
            "restitution_zero_force": ex.get("restitution_zero_force"),
            "contact_time": ex["contact_time"],
            "max_penetration": ex["max_penetration"],
        }
    sol = solve_impact(scene.potential, scene.mass, v0, scene.zeta or 0.0)
    out["scene_as_asked"] = {
        "restitution": sol.restitution,
        "restitution_zero_force": sol.restitution_zero_force if scene.zeta else 1.0,
        "contact_time": sol.contact_time,
        "max_penetration": sol.max_penetration,
    }
    for ref in ("declared_law", "scene_as_asked"):
        if ref not in out:
            continue
        errs = {}
        for k in keys:
            got, want = out["measured"].get(k), out[ref].get(k)
            if isinstance(got, float) and isinstance(want, float) and want:
                errs[k] = abs(got - want) / abs(want)
        out[f"error_vs_{ref}"] = errs
    return out


def calibrate(
    adapter: str,
    scene,
    *,
    param: str,
    target: float,
    quantity: str = "restitution",
    end: str = "overlap",
    steps_per_contact: int = 200,
    v0: float | None = None,
    bracket=None,
    timeout: float = 60.0,
    progress=None,
    isolate: bool = False,
) -> CalibrationResult:
    """Find the value of adapter option ``param`` at which the code delivers ``target``.

    Parameters
    ----------
    adapter : str
        Adapter spec (one variant), e.g. ``"mujoco[solref=direct,impedance=constant,
        integrator=Euler]"``.
    scene : str or Scene
        Scene name, TOML path or `reference_impl.scenes.Scene` (an impact).
    param : str
        Constructor option of the adapter searched.
    target : float
        Restitution to deliver (dimensionless, in (0, 1]).
    quantity : str
        "restitution" (the only one so far).
    end : str
        "overlap" (q = 0) or "zero-force" (see the module docstring).
    steps_per_contact : int
        N; dt = t_c / N with t_c the exact contact time of the scene as asked.
    v0 : float, optional
        Impact speed (m/s); default the scene's middle speed.
    bracket : (float, float), optional
        Search range of the option; default the adapter's ``calibration_range``.
    timeout : float
        Per-run time limit (s).
    progress : callable, optional
        Called between runs (the sweep's deadline check).
    isolate : bool
        Run every evaluation in its own worker process (crash and hang isolation,
        ``timeout`` enforced). Off by default: starting a worker costs 1-5 s per
        evaluation here (16 runs took 81 s isolated on the 2-core machine, about 1 s
        in-process); a sweep runs each calibration in a Dask worker anyway.

    Returns
    -------
    CalibrationResult
        ``found`` False (with ``message``) when the target is out of reach.

    Raises
    ------
    HCVInputError
        Bad input: unknown option, quantity or end, target outside (0, 1], a
        steps-per-contact out of bounds, a non-impact scene, a declined scene.
    """

    if quantity not in QUANTITIES:
        raise HCVInputError(f"--target {quantity}=...: quantity must be one of {QUANTITIES}")
    if end not in ENDS:
        raise HCVInputError(f"--end {end!r} is not one of {', '.join(ENDS)}")
    if not (isinstance(target, (int, float)) and math.isfinite(target) and 0 < target <= 1):
        raise HCVInputError(f"target restitution must be in (0, 1], got {target!r}")
    if (
        isinstance(steps_per_contact, bool)
        or not isinstance(steps_per_contact, int)
        or not _MIN_STEPS_PER_CONTACT <= steps_per_contact <= _MAX_STEPS_PER_CONTACT
    ):
        raise HCVInputError(
            f"--steps-per-contact must be an integer in [{_MIN_STEPS_PER_CONTACT}, "
            f"{_MAX_STEPS_PER_CONTACT}], got {steps_per_contact!r}"
        )
    sc = scene if isinstance(scene, Scene) else load_scene(scene)
    if sc.kind != "impact":
        raise HCVInputError(f"scene {sc.name!r}: calibrate runs impact scenes, not {sc.kind!r}")
    if v0 is None:
        v0 = float(sorted(sc.velocities)[len(sc.velocities) // 2])
    if not (isinstance(v0, (int, float)) and math.isfinite(v0) and v0 > 0):
        raise HCVInputError(f"--v0 must be a speed > 0 (m/s), got {v0!r}")
    cls = check_option(adapter, param)
    lo, hi = _range(cls, param, sc, bracket)
    get_adapter(spec_with_options(adapter, {param: lo})).close()  # options parse, one variant
    t_c = float(solve_impact(sc.potential, sc.mass, v0, sc.zeta or 0.0).contact_time)
    dt = t_c / steps_per_contact
    n = int(math.ceil(_BUDGET * steps_per_contact)) + _EXTRA_STEPS
    ascene = AdapterScene.from_scene(sc, v0, dt, n)
    res = CalibrationResult(
        adapter, sc.name, param, end, quantity, float(target), steps_per_contact, v0, dt, (lo, hi)
    )
    seen: dict[float, float] = {}
    errors: dict[float, str] = {}

    def value_at(x: float) -> float:
        if x in seen:
            return seen[x]
        if progress is not None:
            progress()
        tr, _law, err = _run(spec_with_options(adapter, {param: x}), ascene, timeout, isolate)
        res.evaluations += 1
        got = _quantity(measure(tr, v0), end) if tr is not None else math.nan
        if tr is None:
            errors[x] = err
        seen[x] = got
        return got

    if lo > 0:
        grid = np.geomspace(lo, hi, _SCAN_POINTS)
    else:
        grid = np.linspace(lo, hi, _SCAN_POINTS)
    vals = [value_at(float(x)) for x in grid]
    finite = [(float(x), v) for x, v in zip(grid, vals, strict=True) if math.isfinite(v)]
    if finite:
        res.delivered = (min(v for _, v in finite), max(v for _, v in finite))
    bracket_pair = None
    for (xa, va), (xb, vb) in zip(finite, finite[1:], strict=False):
        if (va - target) * (vb - target) <= 0:
            bracket_pair = (xa, xb)
            break
    if bracket_pair is None:
        how = (
            f"the code delivers {quantity} {res.delivered[0]:.6g} to {res.delivered[1]:.6g} "
            f"there"
            if finite
            else "no run there returned a restitution"
        )
        failed = [f"{x:g}: {e}" for x, e in errors.items()]
        res.message = (
            f"target {quantity} = {target:g} ({end} end) is out of reach for {param} in "
            f"[{lo:g}, {hi:g}] at {steps_per_contact} steps per contact: {how}"
            + (f"; failed runs at {'; '.join(failed[:2])}" if failed else "")
        )
        return res
    xa, xb = bracket_pair

    def f(x: float) -> float:
        v = value_at(x)
        if not math.isfinite(v):
            raise HCVInputError(
                f"run at {param} = {x!r} returned no {quantity}: {errors.get(x, 'not measured')}"
            )
        return v - target

    root = xa if f(xa) == 0 else xb if f(xb) == 0 else None
    if root is None:
        root = float(brentq(f, xa, xb, xtol=_XRTOL * max(abs(xa), abs(xb)), maxiter=_MAXITER))
    tr, law, err = _run(spec_with_options(adapter, {param: root}), ascene, timeout, isolate)
    res.evaluations += 1
    if tr is None:
        res.message = f"the run at the root {param} = {root!r} failed: {err}"
        return res
    res.found, res.value = True, float(root)
    res.metrics = _metrics(tr, law, sc, v0)
    res.achieved = _quantity(measure(tr, v0), end)
    res.message = (
        f"{param} = {root:.8g} delivers {quantity} {res.achieved:.6g} ({end} end; target "
        f"{target:g}) at {steps_per_contact} steps per contact, v0 = {v0:g} m/s"
    )
    return res


def delivered(
    adapter: str,
    scene,
    *,
    param: str,
    value: float,
    end: str = "overlap",
    steps_per_contact: int = 200,
    v0: float | None = None,
    isolate: bool = False,
) -> float:
    """The restitution (at ``end``) the code delivers with option ``param = value``.

    Same scene, speed and dt = t_c / N as `calibrate`; NaN when the run gives none.
    """

    sc = scene if isinstance(scene, Scene) else load_scene(scene)
    if v0 is None:
        v0 = float(sorted(sc.velocities)[len(sc.velocities) // 2])
    t_c = float(solve_impact(sc.potential, sc.mass, v0, sc.zeta or 0.0).contact_time)
    n = int(math.ceil(_BUDGET * steps_per_contact)) + _EXTRA_STEPS
    ascene = AdapterScene.from_scene(sc, v0, t_c / steps_per_contact, n)
    tr, _law, _err = _run(spec_with_options(adapter, {param: value}), ascene, 60.0, isolate)
    return _quantity(measure(tr, v0), end) if tr is not None else math.nan


# ----------------------------------------------------------------------------
# command line
# ----------------------------------------------------------------------------
