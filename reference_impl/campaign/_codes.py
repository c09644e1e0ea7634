"""Report section: the contact codes side by side, asked e -> delivered e (issue 28).

For every code given with ``hcv report --adapter``, the variants of
`reference_impl.bench.codes.CODES` of that code (a plain name: ``lammps``,
``kratos``, ``mujoco``, ``liggghts``, ``yade``), or the spec itself when it names
options or another adapter (run on the Hertz scene unless `CODES` runs that code on
the linear one), are run by `reference_impl.bench.codes.codes_table`: each asked
restitution at 20 and 200 steps per contact and at two speeds four decades apart.
The input that delivers the asked e is searched by
`reference_impl.bench.codes.calibration_table` for the variants of
`reference_impl.bench.codes.CALIBRATED`, for `CALIBRATION_ASKED` only: one asked e
costs 36 to 41 s per YADE variant, 9 s for LIGGGHTS, 5 s for Kratos, 0.5 s for MuJoCo,
~90 s for the five codes (measured 2026-11-26 on 2 cores at load 6-7), against 38-43 s
for their whole table at load 2-3 (17 s before each asked e got its own run, typed into
the code as is: three code starts per variant); the three asked e would add ~3 minutes
to a ~5-minute report.

The result is the results dict's ``codes_side_by_side`` (schema in
`reference_impl.report._schema`), rendered by `reference_impl.report._codes`.
"""

from __future__ import annotations

import time

from reference_impl.bench import codes as _bc

__all__ = ["CALIBRATION_ASKED", "codes_side_by_side", "select"]

# One asked e for the calibration (the middle of `reference_impl.bench.codes.ASKED`): the
# search's cost per asked e is twice the table's (see the module docstring).
CALIBRATION_ASKED = (0.5,)
CALIBRATION_STEPS = 200  # steps per contact of the search (the fine resolution of the table)
CALIBRATION_V0 = 1.0  # m/s: between the table's two speeds (Theorem 3: e does not depend on it)
# Two speeds whose delivered e differ by more than this are marked: the step's error of
# the delivered e at 200 steps per contact (first order, ~5e-4 for e = 0.5, measured by
# verification/test_codes_table.py), x 2.
SPEED_TOLERANCE = 1e-3
# A delivered e further than this (relative) from the asked one is shown in bold.
ASKED_TOLERANCE = 0.01


def _options(spec: str) -> tuple[str, frozenset]:
    """The adapter's name and its option values (bare or keyed alike), to match specs."""
    from reference_impl.adapters.registry import parse_spec

    target, opts = parse_spec(spec)
    vals = set(map(str, opts.pop("__bare__", [])))
    vals |= {v if isinstance(v, str) else f"{k}={v}" for k, v in opts.items()}
    return target, frozenset(vals)


def _key(spec: str) -> str:
    """The same string for two specs of one variant (``yade[en,wall]``, ``yade[input=en,...]``)."""
    name, opts = _options(spec)
    return f"{name}[{','.join(sorted(opts))}]"


def select(adapters) -> tuple[list[tuple], list[tuple]]:
    """The (code, spec, p) variants and the calibrated variants for ``adapters``.

    A plain name of a code in `reference_impl.bench.codes.CODES` stands for its variants
    there (and those of ``CALIBRATED``); any other spec is run as given, with the p of
    that code in ``CODES`` (1.5, Hertz, for an adapter ``CODES`` does not hold).
    """
    runs, calib = [], []
    for spec in adapters:
        name, opts = _options(spec)
        mine = [c for c in _bc.CODES if _options(c[1])[0] == name]
        if not opts and mine:
            runs += mine
            calib += [c for c in _bc.CALIBRATED if _options(c[1])[0] == name]
        else:
            code = mine[0][0] if mine else name
            runs.append((code, spec, mine[0][2] if mine else 1.5))
            calib += [c for c in _bc.CALIBRATED if _options(c[1]) == (name, opts)]
    return runs, calib


def codes_side_by_side(adapters, progress=None) -> dict | None:
    """Run the section's study for ``adapters`` (``hcv report --adapter`` specs).

    Returns
    -------
    dict or None
        ``settings``, ``rows`` (`reference_impl.bench.codes.CodeRow` dicts, each with
        ``spec`` added), ``calibration`` (rows of ``calibration_table`` with ``spec`` and
        ``p``) and ``seconds`` (per spec: ``table`` and ``calibration`` wall times, s);
        None without adapters.
    """
    if not adapters:
        return None
    runs, calib = select(adapters)
    rows, cal, seconds = [], [], {}
    for code, spec, p in runs:
        if progress is not None:
            progress(f"codes side by side: {spec}")
        t0 = time.perf_counter()
        got = _bc.codes_table(codes=[(code, spec, p)])
        seconds[spec] = {"table": time.perf_counter() - t0, "calibration": 0.0}
        rows += [{**r.to_dict(), "spec": spec} for r in got]
    for code, spec, p, param, *rng in calib:
        if progress is not None:
            progress(f"codes side by side: calibrating {spec}")
        t0 = time.perf_counter()
        got = _bc.calibration_table(codes=[(code, spec, p, param, *rng)], asked=CALIBRATION_ASKED,
                                   steps_per_contact=CALIBRATION_STEPS, v0=CALIBRATION_V0)  # fmt: skip
        # the cost is the variant's: under the spec its table ran with, when it ran
        run = next((s for _, s, _ in runs if _key(s) == _key(spec)), spec)
        seconds.setdefault(run, {"table": 0.0, "calibration": 0.0})
        seconds[run]["calibration"] += time.perf_counter() - t0
        cal += [{**r, "spec": spec, "p": p, "match": _key(spec)} for r in got]
    for r in rows:
        r["match"] = _key(r["spec"])
    return {
        "settings": {
            "asked": list(_bc.ASKED),
            "steps_per_contact": list(_bc.STEPS_PER_CONTACT),
            "speeds": list(_bc.SPEEDS),
            "mass": _bc.MASS,
            "hertz_k": _bc.HERTZ_K,
            "hooke_k": _bc.HOOKE_K,
            "speed_tolerance": SPEED_TOLERANCE,
            "asked_tolerance": ASKED_TOLERANCE,
            "calibration_asked": list(CALIBRATION_ASKED),
            "calibration_steps_per_contact": CALIBRATION_STEPS,
            "calibration_v0": CALIBRATION_V0,
        },
        "rows": rows,
        "calibration": cal,
        "seconds": seconds,
    }
