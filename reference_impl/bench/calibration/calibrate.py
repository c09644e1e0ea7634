"""``hcv calibrate``: the value of a code's own option that delivers a target, at a resolution.

    hcv calibrate ADAPTER --scene SCENE --target restitution=0.5 --param KEY
                  [--end overlap|zero-force] [--steps-per-contact N] [--v0 V]
                  [--range LO HI] [--isolate] [--json]

For one impact of SCENE at speed V (default: the scene's middle speed), run at
dt = t_c / N (t_c the exact contact time of the scene as asked, N = 200 by
default, as ``hcv bench``), this finds by a bracketed root search (a scan of the
range, then `scipy.optimize.brentq`) the value of the adapter option KEY (a
constructor argument, e.g. ``mujoco``'s ``dampratio`` or ``damping``, LAMMPS'
``eta_n0``, Kratos' ``gamma``), or else the strength of the scene's damping law
(``zeta``, ``c``, ``A``, ``alpha``, a polynomial's factor on its coefficients; the code
is sent the scene with its law at each strength, `reference_impl.bench.calibration._law`),
for which the code's measured restitution at the chosen end equals the target. The
scene may have any registered damping law: t_c and the scene as asked are its law's
exact solution:

* ``overlap``: -v / v0 at the first sample with q <= 0 (what the scene's
  ``restitution`` means);
* ``zero-force``: -v / v0 where the total force first vanishes after the deepest
  overlap (a code that never lets the force pull delivers this one at q = 0 too).

It prints the value, the achieved restitution, and at that value the code's
contact time, maximum penetration and both restitutions with their errors against
the exact solution of the law the code declares (its integration error) and
against the scene as asked (what the user gets). A run in which the body does not
come back out within its budget (4 contact times) counts as restitution 0, and
scan points the adapter declines are skipped (see `calibrate`); both are noted. A
target outside what the option delivers over its range is said so, with the span
of every restitution measured (exit status 1). A code whose output is noisy (two
runs at one value differ) is answered within its noise (repeats where the search
misses the target, `reference_impl.bench.calibration._noise`): "delivers 0.50003 ±
8e-05", or, when the mean misses it all the same, "noisy: ±x". Bad input (`check_settings`, shared
with ``hcv sweep``): one line, exit status 2.

Evaluations run in-process (``--isolate``: each in a worker process, as ``hcv
bench`` runs isolated adapters, with the per-run timeout). ``calibrate`` is also a task of ``hcv sweep``
(``task = "calibrate:ADAPTER"``, see `reference_impl.sweep`).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np
from scipy.optimize import brentq

from reference_impl.adapters.base import AdapterScene
from reference_impl.bench.calibration._delivered import quantity as _quantity
from reference_impl.bench.calibration._delivered import run_metrics as _metrics
from reference_impl.bench.calibration._law import (
    contact_time,
    impact_scene,
    option_class,
    scene_at_strength,
    searches_strength,
    strength_range,
)
from reference_impl.bench.calibration._noise import SIGMAS, spread_at, within_noise
from reference_impl.bench.calibration._options import (
    ENDS,
    check_option,
    check_settings,
    spec_with_options,
)
from reference_impl.bench.worker import make_executor
from reference_impl.errors import HCVInputError

__all__ = [
    "ENDS",
    "CalibrationResult",
    "calibrate",
    "check_settings",
    "check_option",
    "delivered",
    "spec_with_options",
]

EXIT_OK, EXIT_UNREACHABLE, EXIT_USAGE = 0, 1, 2
# Points of the bracketing scan over the range (log-spaced when the range is positive):
# enough to find the sign change of a monotone response and to report its span.
_SCAN_POINTS = 9
# Root tolerance on the option, relative: below the measured restitution's own
# step-to-step resolution at any N the bench uses.
_XRTOL = 1e-9
_MAXITER = 100
# |achieved - target| above which a brentq root is a jump of the response, not a root.
# A continuous response meets the target to the root tolerance: 1e-9 relative in the
# option times |x de/dx|, below 10 for every code calibrated here (MuJoCo's dampratio
# about 0.3, LAMMPS' eta_n0 about 1), i.e. under 1e-8; a jump misses by its own size.
_ACHIEVED_TOL = 1e-6
# Where to probe from a declined end of the range toward the nearest scan point that ran,
# as fractions of the way (in log space when both are positive): first close to the
# declined value (the widest span), then further in.
_INWARD = (1e-3, 1e-2, 1e-1, 0.5)
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
        The quantity the code delivers at ``value`` (for a noisy code, the mean of the
        runs repeated there).
    noise : float
        Standard deviation of one run's quantity over runs repeated at ``value`` (or,
        when not found, at the noisiest miss); NaN when no repeat was needed (the
        value met the target to the root tolerance) and 0 when repeats agreed exactly.
    delivered : tuple of float
        Smallest and largest value of the quantity measured (scan and search; a run
        without rebound counts as 0).
    values : list of float
        Every value found that delivers the target, ascending (several when the
        response is not monotone); ``value`` is the first.
    metrics : dict
        At ``value``: measured quantities, exact values of the declared law and of
        the scene as asked, relative errors (see `_metrics`).
    evaluations : int
        Adapter runs made.
    message : str
        One line: the answer, or why the target is out of reach.
    notes : list of str
        Runs without rebound (counted as 0), declined or failed values, lost brackets.
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
    noise: float = math.nan
    delivered: tuple = (math.nan, math.nan)
    values: list = field(default_factory=list)
    metrics: dict = field(default_factory=dict)
    evaluations: int = 0
    message: str = ""
    notes: list = field(default_factory=list)

    def to_dict(self) -> dict:
        d = asdict(self)
        d["range"], d["delivered"] = list(self.range), list(self.delivered)
        return d


def _range(cls: type, param: str, scene, given) -> tuple[float, float]:
    if given is not None:
        return given
    fn = getattr(cls, "calibration_range", None)
    rng = fn(param, scene) if fn is not None else None
    if rng is None:
        raise HCVInputError(
            f"no default range for option {param!r} of {cls.__name__}; give --range LO HI"
        )
    return float(rng[0]), float(rng[1])


class _Declined(HCVInputError):
    """The code refuses the option's value or declines the scene with it (one line)."""


def _run(spec: str, ascene: AdapterScene, timeout: float, isolate: bool):
    """One run: (trajectory, implemented law, error).

    Raises `_Declined` when the adapter refuses the spec's options or declines the
    scene, HCVInputError when the spec has several variants.
    """

    try:
        executor = make_executor(spec, isolate=isolate)
    except HCVInputError as exc:
        raise _Declined(str(exc)) from None
    try:
        if len(executor.variants) != 1:
            raise HCVInputError(
                f"adapter {spec!r} has {len(executor.variants)} variants; configure one "
                f"(e.g. {executor.variants[0].label})"
            )
        reason = executor.variants[0].supports(ascene)
        if reason:
            raise _Declined(f"adapter {spec!r} declines the scene: {reason}")
        out = executor.call(0, "impact", ascene, timeout=timeout)
        if out.declined:
            raise _Declined(f"adapter {spec!r} declines the scene: {out.declined}")
        if not out.ok:
            return None, None, out.error
        law = executor.call(0, "implemented_law", ascene, timeout=timeout)
        return out.value, (law.value if law.ok else None), law.error if not law.ok else ""
    finally:
        executor.close()


# What a scan point or search step gave: measured, no rebound (counted as 0), failed, declined.
_MEASURED, _NO_REBOUND, _FAILED, _DECLINED = "measured", "no rebound", "failed", "declined"


class _Unusable(Exception):
    """A run inside a bracket failed or was declined: that bracket cannot be searched."""


def _between(a: float, b: float, frac: float) -> float:
    """The point ``frac`` of the way from ``a`` to ``b`` (geometric when both are > 0)."""
    if a > 0 and b > 0:
        return float(a * (b / a) ** frac)
    return float(a + frac * (b - a))


def _values_text(xs) -> str:
    xs = sorted(xs)
    shown = ", ".join(f"{x:g}" for x in xs[:4])
    return shown + (f" and {len(xs) - 4} more" if len(xs) > 4 else "")


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

    The range is scanned at `_SCAN_POINTS` values (log-spaced when LO > 0); every pair
    of neighbouring scan points whose restitutions lie on both sides of the target is
    searched with `scipy.optimize.brentq`, so a response that is not monotone (falling,
    then rising where the scheme goes unstable) gives every crossing the scan sees; the
    smallest value found is the answer. A run without rebound counts as restitution 0
    (see `_quantity`); scan points the adapter declines (or whose value it refuses) are
    skipped and said so; ``delivered`` spans every restitution measured.

    Parameters
    ----------
    adapter : str
        Adapter spec (one variant), e.g. ``"mujoco[solref=direct,impedance=constant,
        integrator=Euler]"``.
    scene : str or Scene
        Scene name, TOML path or `reference_impl.scenes.Scene` (an impact).
    param : str
        Constructor option of the adapter searched, or the strength of the scene's law
        (`LawFamily.strength`) when the adapter has no option of that name; its default
        range is then x1/4 to x4 the strength at which the exact law delivers ``target``.
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
        Bad input (`check_settings`), an unknown option, a non-impact scene, an
        adapter with several variants, or one that declines every scanned value.
    """

    settings = check_settings(
        target=target,
        quantity=quantity,
        end=end,
        steps_per_contact=steps_per_contact,
        v0=v0,
        bracket=bracket,
    )
    target, v0, bracket = settings["target"], settings["v0"], settings["bracket"]
    sc = impact_scene(scene)
    if v0 is None:
        v0 = float(sorted(sc.velocities)[len(sc.velocities) // 2])
    # the scene law's strength (zeta, c, A, alpha, ...) when the adapter has no such option
    strength = searches_strength(adapter, param, sc)
    if strength:
        lo, hi = bracket if bracket is not None else strength_range(sc, target, v0, end)
    else:
        lo, hi = _range(option_class(adapter, param, sc), param, sc, bracket)
    t_c = contact_time(sc, v0)
    dt = t_c / steps_per_contact
    n = int(math.ceil(_BUDGET * steps_per_contact)) + _EXTRA_STEPS
    ascene = AdapterScene.from_scene(sc, v0, dt, n)

    def setup(x: float) -> tuple[str, AdapterScene]:
        """The spec and the scene of one run at value ``x`` of the option searched."""
        if strength:
            return adapter, AdapterScene.from_scene(scene_at_strength(sc, x), v0, dt, n)
        return spec_with_options(adapter, {param: x}), ascene

    res = CalibrationResult(
        adapter, sc.name, param, end, quantity, target, steps_per_contact, v0, dt, (lo, hi)
    )
    seen: dict[float, tuple[float, str]] = {}  # value -> (restitution, what it was)
    why: dict[float, str] = {}  # value -> the failure or the decline

    retried: list[float] = []  # values whose first run failed and second answered

    def run_once(x: float) -> None:
        if progress is not None:
            progress()
        try:
            tr, _law, err = _run(*setup(x), timeout, isolate)
        except _Declined as exc:
            seen[x], why[x] = (math.nan, _DECLINED), str(exc)
            return
        res.evaluations += 1
        if tr is None:
            seen[x], why[x] = (math.nan, _FAILED), err
        else:
            got, read = _quantity(tr, v0, end)
            seen[x] = (got, _MEASURED if read else _NO_REBOUND)
            if not math.isfinite(got):
                seen[x], why[x] = (got, _FAILED), "no restitution measured"

    def value_at(x: float) -> float:
        if x not in seen:
            run_once(x)
            # A failed run is run once more: a code that fails intermittently (a lost
            # process, a NaN every few runs) answers the second time, and one failure
            # then neither ends a bracket nor reads as "out of reach"; a value that fails
            # twice is failed.
            if seen[x][1] == _FAILED:
                run_once(x)
                if seen[x][1] != _FAILED:
                    retried.append(x)
        return seen[x][0]

    def fresh(x: float) -> float:
        """One more run at ``x`` (not the cached one): does the code repeat itself?"""
        seen.pop(x, None)
        return value_at(x)

    grid = np.geomspace(lo, hi, _SCAN_POINTS) if lo > 0 else np.linspace(lo, hi, _SCAN_POINTS)
    scan = [(float(x), value_at(float(x))) for x in grid]
    usable = [(x, v) for x, v in scan if seen[x][1] != _DECLINED]
    if not usable:
        raise HCVInputError(
            f"every {param} scanned in [{lo:g}, {hi:g}] was refused: {why[scan[0][0]]}"
        )
    # A declined end (MuJoCo's timeconst form at dampratio 0) leaves the rest of the range
    # open: probe from it toward the nearest scan point the code ran, so the search still
    # reaches values next to the declined one.
    for outer, inner in ((scan[0][0], usable[0][0]), (scan[-1][0], usable[-1][0])):
        if outer != inner:
            for frac in _INWARD:
                x = _between(outer, inner, frac)
                v = value_at(x)
                if seen[x][1] != _DECLINED:
                    usable = sorted([*usable, (x, v)])
                    break
    # Neighbours among the scan points the code ran (declined ones are skipped; a failed
    # one ends a bracket: the response is unknown there).
    brackets = [
        (xa, xb)
        for (xa, va), (xb, vb) in zip(usable, usable[1:], strict=False)
        if math.isfinite(va) and math.isfinite(vb) and (va - target) * (vb - target) <= 0
    ]

    def f(x: float) -> float:
        v = value_at(x)
        if not math.isfinite(v):
            raise _Unusable(x)
        return v - target

    roots: list[float] = []
    spreads: dict = {}  # root -> its `Spread`, for a root met within the code's noise
    noisy_misses: list = []  # `Spread`s of noisy points that missed the target all the same
    jumps: list[str] = []  # brackets where the response jumps across the target
    lost: list[str] = []  # brackets whose search hit a failed or declined run
    for xa, xb in brackets:
        try:
            fa, fb = f(xa), f(xb)
            if fa == 0 or fb == 0:
                root = xa if fa == 0 else xb
            else:
                root = float(brentq(f, xa, xb, xtol=_XRTOL * max(abs(xa), abs(xb)),
                                    maxiter=_MAXITER))  # fmt: skip
                # A continuous response meets the target to the root tolerance; one that
                # jumps across it (a late rebound cut by the run budget, an instability)
                # leaves brentq at the jump, missing the target by the jump's size; a
                # noisy one leaves it where the noisy sign changes: repeat the run there.
                if abs(f(root)) > _ACHIEVED_TOL:
                    spread = spread_at(root, seen[root][0], lambda x=root: fresh(x))
                    if within_noise(spread, target, _ACHIEVED_TOL):
                        spreads[root] = spread
                    else:
                        noisy = f"; noisy: ±{spread.std:.2g}" if spread.noisy else ""
                        noisy_misses += [spread] if spread.noisy else []
                        jumps.append(f"{root:.6g} (from {xa:g} to {xb:g}{noisy})")
                        continue
        except _Unusable as exc:
            x = exc.args[0]
            lost.append(f"[{xa:g}, {xb:g}] (the run at {x:.6g} {seen[x][1]})")
            continue
        except RuntimeError:  # brentq did not converge within _MAXITER steps
            lost.append(f"[{xa:g}, {xb:g}] (no convergence in {_MAXITER} steps)")
            continue
        if not any(abs(root - r) <= _XRTOL * max(abs(root), abs(r)) for r in roots):
            roots.append(root)
    notes = _notes(param, seen, why, n, jumps, lost)
    if retried:
        notes.append(
            f"{len(retried)} run(s) failed and answered when run again, at {param} = "
            + ", ".join(f"{x:.6g}" for x in sorted(retried)[:3])
            + (", ..." if len(retried) > 3 else "")
            + ": the code fails intermittently"
        )
    res.notes = notes
    measured = [v for v, what in seen.values() if what in (_MEASURED, _NO_REBOUND)]
    if measured:
        res.delivered = (min(measured), max(measured))
    if not roots:
        how = (
            f"the code delivers {quantity} {res.delivered[0]:.6g} to {res.delivered[1]:.6g} "
            f"at the {len(measured)} values run"
            if measured
            else "no run there returned a restitution"
        )
        failed = sorted(x for x, (_v, what) in seen.items() if what == _FAILED)
        # "Out of reach" is a finding only where every run answered: a run that failed
        # twice leaves the response unknown there, and the target may lie behind it.
        verdict = (
            f"was not found (runs failed twice at {len(failed)} value(s) of {param}, from "
            f"{failed[0]:.6g} to {failed[-1]:.6g}: the target may lie there)"
            if failed
            else "is out of reach"
        )
        if noisy_misses:  # noisy, and off the target by more than the noise all the same
            worst = max(noisy_misses, key=lambda sp: sp.std)
            res.noise = worst.std
            verdict = (
                f"is not met within the code's noise (noisy: ±{worst.std:.2g}, the spread of "
                f"{len(worst.values)} runs at {param} = {worst.x:.6g}, mean {worst.mean:.6g})"
            )
        res.message = (
            f"target {quantity} = {target:g} ({end} end) {verdict} for {param} in "
            f"[{lo:g}, {hi:g}] at {steps_per_contact} steps per contact: {how}"
            + (f" ({'; '.join(notes)})" if notes else "")
        )
        return res
    root = min(roots)
    tr, law, err = _run(*setup(root), timeout, isolate)
    res.evaluations += 1

    def answered(tr) -> bool:
        return tr is not None and math.isfinite(_quantity(tr, v0, end)[0])

    if not answered(tr):  # a failed confirming run is run once more, as in value_at
        tr, law, err = _run(*setup(root), timeout, isolate)
        res.evaluations += 1
    if not answered(tr):
        failure = err if tr is None else "no restitution measured"
        res.message = f"the run at the root {param} = {root!r} failed twice: {failure}"
        return res
    res.found, res.value, res.values = True, float(root), sorted(roots)
    res.metrics = _metrics(tr, law, sc, v0)
    res.achieved = _quantity(tr, v0, end)[0]
    if root not in spreads and abs(res.achieved - target) > _ACHIEVED_TOL:
        # the search met the target there, this run does not: the code is noisy
        spreads[root] = spread_at(root, res.achieved, lambda: fresh(root))
    noisy = ""
    if root in spreads and spreads[root].noisy:  # the mean of the runs there, and the noise
        sp = spreads[root]
        res.achieved, res.noise = sp.mean, sp.std
        noisy = (
            f" ± {sp.std:.2g} (noisy: ±{sp.std:.2g}, the spread of {len(sp.values)} runs: "
            f"their mean is within {SIGMAS:g} standard deviations of the target)"
        )
    also = [r for r in res.values if r != root]
    res.message = (
        f"{param} = {root:.8g} delivers {quantity} {res.achieved:.6g}{noisy} ({end} end; "
        f"target {target:g}) at {steps_per_contact} steps per contact, v0 = {v0:g} m/s"
        + (f"; so does {param} = {', '.join(f'{r:.8g}' for r in also)}" if also else "")
    )
    return res


def _notes(param: str, seen: dict, why: dict, n_steps: int, jumps: list, lost: list) -> list:
    """One line per kind of run that did not measure a restitution, and per lost bracket."""
    notes = []
    by_kind: dict[str, list[float]] = {}
    for x, (_v, what) in seen.items():
        by_kind.setdefault(what, []).append(x)
    if _NO_REBOUND in by_kind:
        notes.append(
            f"no rebound within {n_steps} steps at {param} = {_values_text(by_kind[_NO_REBOUND])}"
            ": counted as restitution 0"
        )
    for kind, verb in ((_DECLINED, "declined, skipped"), (_FAILED, "failed")):
        if kind in by_kind:
            xs = sorted(by_kind[kind])
            notes.append(f"{verb} at {param} = {_values_text(xs)} ({why[xs[0]]})")
    if jumps:
        notes.append(f"the response jumps across the target at {param} = {'; '.join(jumps)}")
    if lost:
        notes.append(f"no root found in {param} = {'; '.join(lost)}")
    return notes


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

    Same scene, speed and dt = t_c / N as `calibrate`: 0 for a run without rebound,
    NaN when the run gives none.
    """

    sc = impact_scene(scene)
    if v0 is None:
        v0 = float(sorted(sc.velocities)[len(sc.velocities) // 2])
    t_c = contact_time(sc, v0)
    n = int(math.ceil(_BUDGET * steps_per_contact)) + _EXTRA_STEPS
    spec = adapter
    if searches_strength(adapter, param, sc):
        sc = scene_at_strength(sc, value)
    else:
        spec = spec_with_options(adapter, {param: value})
    ascene = AdapterScene.from_scene(sc, v0, t_c / steps_per_contact, n)
    tr, _law, _err = _run(spec, ascene, 60.0, isolate)
    return _quantity(tr, v0, end)[0] if tr is not None else math.nan


# ----------------------------------------------------------------------------
# command line
# ----------------------------------------------------------------------------
