"""Assembly scenes for ``cmd:`` programs: the JSON form of contract item 14 (issue 39 §4).

A program declared ``cmd[assembly=chain]:COMMAND`` (or ``assembly=lattice``,
``assembly=chain+lattice``; `reference_impl.adapters._declaration.declared_assembly`)
is sent each run of the suite's search as one JSON request (one line in persistent
mode), the same channel, limits and hardening as an impact
(`reference_impl.adapters.subprocess`)::

    {"protocol": "hcv-adapter/2", "request": "assembly",     # or "advice"
     "assembly": {"kind": "chain",                           # or "lattice"
                  "name": "chain-hertz", "potential": {"family": "power", ...},
                  "masses": [...], "radii": [...],           # kg, m (one per body)
                  "positions": [...], "velocities": [...],   # chain: x (m), v_x (m/s)
                                                             # lattice: rows [x, y, z]
                  "contacts": [[0, 1], ...],                 # pairs in contact at the start
                  "walls": [{"x": 0.0, "side": "left"}, ...],   # chain: planes x = const
                  "box": [...], "periodic": [...], "shifts": [...],  # lattice only
                  "dt": 1e-6, "n_steps": 2000, "stop_energy": 0.5}}  # s, -, J or null

and answers ``{"t": [...], "x": [...], "v": [...]}``: the start and the state after
every step (chain: shape (samples, N) along x; lattice: (samples, N, 3)), non-finite
numbers as null. `assembly_run` checks it in one line naming the field: numbers only,
the shapes, t[i] = i dt (`check_steps`, the rule of every answer of the protocol), the
first sample the request's start, and every step recorded unless the run ended past
``stop_energy`` or blew up (a run that merely stops early would pass every step). A
declared ``advice=true`` program also answers ``"advice"`` requests with ``{"advice":
{"name": dt_s, ...}}`` (`assembly_advice`), judged as a built-in code's advice is
(`reference_impl.bench.assembly_codes.code_report`).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from reference_impl.adapters._assembly_request import ChainRequest, ChainRun, chain_run_from_mapping
from reference_impl.adapters._lattice_request import (
    LatticeRequest,
    LatticeRun,
    lattice_run_from_mapping,
)
from reference_impl.adapters._records import AdapterDeclined, AdapterOutputError
from reference_impl.scenes import potential_to_dict

__all__ = [
    "MAX_ANSWER",
    "answer_guard",
    "assembly_advice",
    "assembly_answer_limit",
    "assembly_run",
    "assembly_to_json",
    "check_steps",
]

# Bytes of one number in an answer: a float written in full (repr: 17 significant digits,
# sign, exponent; <= 24 characters), its separator and space, and its share of a row's
# brackets; 40 leaves room for indentation. Plus 1 MiB for meta.
_BYTES_PER_NUMBER = 40
_SLACK = 1 << 20
# Largest answer of one run (bytes): the 27 bodies of a 3 x 3 x 3 lattice followed for
# the 20 000 steps of a confirmation at the default horizon write ~70 MB (an impact's
# bound, 32 MiB, refused it). Parsed, a number costs at most ~8 times its text (a float
# and its list slot for "1.5,"); lists, objects and strings cost up to ~20 times theirs,
# so `answer_guard` bounds how many there are before the answer is parsed: a hostile
# answer holds < 1 GB, a real one ~4 times its text.
MAX_ANSWER = 96 << 20
# Lists, objects and strings an answer may hold beyond those of t, x and v (its meta).
_STRUCT_SLACK = 10_000
# The first sample must be the request's start to this fraction of its scale: a program
# that prints 15 significant digits is within 5e-15 of it, one that repr's it exactly.
_START_RTOL = 1e-12
# A run that ends early must end past stop_energy: its last kinetic energy is computed
# here from velocities printed to >= 15 digits (2e-15 relative), so 1e-12 below the
# level still counts as past it.
_STOP_RTOL = 1e-12
# Step advice: at most this many entries, names of at most this many characters (one
# line in the verdicts, never a program's whole output echoed).
_MAX_ADVICE = 16
_MAX_NAME = 60

# send(obj, limit, n_steps, guard) -> answer object: the adapter's exchange (one-shot or
# persistent), which adds the protocol and the options, calls guard(raw bytes) before it
# parses the answer, and raises on an error answer.
Send = Callable[..., dict]


def assembly_to_json(req: ChainRequest | LatticeRequest) -> dict:
    """The ``"assembly"`` object of a request (SI units; JSON-safe)."""
    lattice = isinstance(req, LatticeRequest)
    n = req.n_bodies
    out = {
        "kind": "lattice" if lattice else "chain",
        "name": req.name,
        "potential": potential_to_dict(req.potential),
        "masses": [float(m) for m in req.masses],
        "radii": [float(req.radius)] * n,
    }
    if lattice:
        out.update(
            positions=req.positions.tolist(),
            velocities=req.velocities.tolist(),
            contacts=req.contacts.tolist(),
            walls=[],
            box=list(req.box),
            periodic=list(req.periodic),
            shifts=req.shifts.tolist(),
        )
    else:
        out.update(
            positions=req.x0().tolist(),
            velocities=[float(v) for v in req.velocities],
            contacts=[[i, i + 1] for i in range(n - 1)],
            walls=[{"x": float(x), "side": "left" if side < 0 else "right"}
                   for x, side in req.wall_planes()],
        )  # fmt: skip
    stop = float(req.stop_energy)
    out.update(dt=float(req.dt), n_steps=int(req.n_steps),
               stop_energy=stop if math.isfinite(stop) else None)  # fmt: skip
    return out


def assembly_answer_limit(req: ChainRequest | LatticeRequest) -> int:
    """Largest answer (bytes) accepted for ``req``: t, x and v of n_steps + 1 samples
    (`_BYTES_PER_NUMBER` each), plus `_SLACK`, at most `MAX_ANSWER`."""
    dims = 3 if isinstance(req, LatticeRequest) else 1
    per_sample = 1 + 2 * req.n_bodies * dims
    return min(MAX_ANSWER, _SLACK + _BYTES_PER_NUMBER * per_sample * (int(req.n_steps) + 2))


def answer_guard(req: ChainRequest | LatticeRequest) -> Callable[[bytes], None]:
    """A check of an answer's raw bytes before it is parsed: no more lists than t, x and
    v of ``req`` hold (one a sample, and one a body of a lattice's sample, each array)
    and no more objects or strings than its meta needs (`_STRUCT_SLACK`), so that the
    parsed answer costs at most ~8 times its text (`MAX_ANSWER`)."""
    rows = 1 + (req.n_bodies if isinstance(req, LatticeRequest) else 0)
    lists = 3 + 2 * (int(req.n_steps) + 1) * rows + _STRUCT_SLACK

    def guard(raw: bytes, who: str) -> None:
        for char, most in ((b"[", lists), (b"{", _STRUCT_SLACK), (b'"', 4 * _STRUCT_SLACK)):
            count = raw.count(char)
            if count > most:
                raise AdapterOutputError(f"{who}: the answer holds {count} {char.decode()!r}, "
                                         f"more than t, x, v and a meta of a run of "
                                         f"{req.n_steps} steps need ({most})")  # fmt: skip

    return guard


def check_steps(t: np.ndarray, dt: float, who: str) -> None:
    """Rule 2, "step with exactly dt; record every step": t[i] = i dt to round-off.

    The allowance at sample i is (i + 2) eps i dt (eps the float64 epsilon): t computed
    as i * dt is within eps/2 of it; t accumulated by i additions of dt within about
    i^2 eps dt / 4; printed with 15 or more significant digits and read back, within
    another 2.5 eps. A code that steps with another dt (its own step, or answers made
    for another request) misses by far more and is refused in one line naming the
    sample (a critical step of infinity once passed that way).

    Raises
    ------
    AdapterOutputError
        The first sample off the grid.
    """
    i = np.arange(t.size, dtype=float)
    want = i * dt
    allowed = (i + 2.0) * np.finfo(float).eps * np.maximum(i, 1.0) * dt
    off = np.flatnonzero(~(np.abs(t - want) <= allowed))  # a NaN is off the grid too
    if off.size:
        k = int(off[0])
        raise AdapterOutputError(
            f"{who}: 't[{k}]' = {float(t[k])!r} s, should be {k} x dt = {float(want[k])!r} s "
            f"(the asked step dt = {dt!r} s, to round-off: every step is dt and every step "
            "is recorded)"
        )


def _numbers(data: dict, key: str, tail: tuple, who: str) -> np.ndarray:
    """``data[key]`` as floats of shape (samples, *tail): JSON numbers or null (NaN) only."""
    if key not in data:
        raise AdapterOutputError(f"{who}: the answer has no {key!r} (an assembly answer holds "
                                 "'t', 'x' and 'v')")  # fmt: skip
    try:
        a = np.array(data[key], dtype=object)
    except ValueError:  # an inconsistent nesting numpy cannot even hold as objects
        a = np.empty(0, dtype=object)
    want = "(samples" + "".join(f", {d}" for d in tail) + ")"
    if a.ndim != 1 + len(tail) or a.shape[1:] != tail:
        raise AdapterOutputError(f"{who}: {key!r} must be an array of shape {want}, got "
                                 f"{'shape ' + str(a.shape) if a.size else 'none'}")  # fmt: skip
    if not set(map(type, a.flat)) <= {float, int, type(None)}:  # bool and text are no numbers
        k = next(k for k, x in enumerate(a.flat) if type(x) not in (float, int, type(None)))
        where = list(map(int, np.unravel_index(k, a.shape)))
        raise AdapterOutputError(f"{who}: {key}{where} = {str(a.flat[k])[:40]!r} is not a "
                                 "number (non-finite values are null)")  # fmt: skip
    try:
        return a.astype(float)
    except OverflowError:  # an integer beyond float64 (JSON integers are unbounded)
        raise AdapterOutputError(f"{who}: {key!r} holds an integer beyond float64") from None


def _check_start(x: np.ndarray, v: np.ndarray, req, who: str) -> None:
    """Sample 0 is the request's start (positions and velocities), to `_START_RTOL`."""
    if isinstance(req, LatticeRequest):
        x0, v0 = req.positions, req.velocities
    else:
        x0, v0 = req.x0(), np.asarray(req.velocities, dtype=float)
    for key, got, want in (("x", x[0], x0), ("v", v[0], v0)):
        scale = max(float(np.max(np.abs(want))), float(req.radius) if key == "x" else 0.0)
        err = np.abs(got - want)
        bad = np.flatnonzero(~(err <= _START_RTOL * scale).ravel())
        if bad.size:
            k = int(bad[0])
            raise AdapterOutputError(f"{who}: '{key}[0]' is not the request's start: entry "
                                     f"{k} = {float(got.ravel()[k])!r}, should be "
                                     f"{float(want.ravel()[k])!r}")  # fmt: skip


def _check_complete(x: np.ndarray, v: np.ndarray, req, who: str) -> None:
    """Every step recorded, unless the run ended past ``stop_energy`` or blew up."""
    done = x.shape[0] - 1
    if done >= req.n_steps:
        return
    last_x, last_v = x[-1], v[-1]
    if not (np.all(np.isfinite(last_x)) and np.all(np.isfinite(last_v))):
        return  # blown up: the run could not go on, a result
    m = np.asarray(req.masses, dtype=float)
    ke = 0.5 * float(np.sum(m.reshape((-1,) + (1,) * (last_v.ndim - 1)) * last_v**2))
    if ke > (1.0 - _STOP_RTOL) * req.stop_energy:
        return
    raise AdapterOutputError(f"{who}: the run ended after {done} of {req.n_steps} steps with "
                             f"kinetic energy {ke:.6g} J, not past stop_energy "
                             f"{req.stop_energy:.6g} J; record every step unless the run is "
                             "past it or not finite")  # fmt: skip


def assembly_run(send: Send, req: ChainRequest | LatticeRequest, who: str,
                 kinds) -> ChainRun | LatticeRun:  # fmt: skip
    """Run ``req`` through a ``cmd:`` program and return its checked run.

    Parameters
    ----------
    send : callable
        ``send(obj, limit, n_steps, guard)``: the adapter's exchange, returning the answer
        object (``guard(raw, who)`` checks its bytes before they are parsed).
    req : ChainRequest or LatticeRequest
        The run asked.
    who : str
        The program's label, for the error lines.
    kinds : collection of str
        The kinds declared (``"chain"``, ``"lattice"``).

    Raises
    ------
    AdapterDeclined
        The program did not declare the request's kind, or answered ``unsupported``.
    AdapterOutputError
        One line naming the field that breaks the rules.
    """
    lattice = isinstance(req, LatticeRequest)
    kind = "lattice" if lattice else "chain"
    if kind not in kinds:
        raise AdapterDeclined(f"{who} does not run {kind} scenes (declared assembly="
                              f"{'+'.join(sorted(kinds))})")  # fmt: skip
    obj = {"request": "assembly", "assembly": assembly_to_json(req)}
    data = send(obj, assembly_answer_limit(req), int(req.n_steps), answer_guard(req))
    tail = (req.n_bodies, 3) if lattice else (req.n_bodies,)
    t = _numbers(data, "t", (), who)
    x = _numbers(data, "x", tail, who)
    v = _numbers(data, "v", tail, who)
    if not (t.shape[0] == x.shape[0] == v.shape[0]):
        raise AdapterOutputError(f"{who}: 't', 'x' and 'v' must hold as many samples, got "
                                 f"{t.shape[0]}, {x.shape[0]} and {v.shape[0]}")  # fmt: skip
    meta = data.get("meta", {})
    if not isinstance(meta, dict):
        raise AdapterOutputError(f"{who}: 'meta' must be an object, got {type(meta).__name__}")
    out = {"x": x, "v": v, "meta": meta}
    # the shapes and 2 .. n_steps + 1 samples (one line), the lattice's positions unwrapped
    check = lattice_run_from_mapping if lattice else chain_run_from_mapping
    run = check(out, req, who)
    check_steps(t, float(req.dt), who)
    _check_start(x, v, req, who)
    _check_complete(x, v, req, who)
    return run


def assembly_advice(send: Send, req: ChainRequest | LatticeRequest, who: str) -> dict:
    """The program's own step advice for ``req`` (name -> dt in s; empty: none).

    Raises
    ------
    AdapterOutputError
        One line: no ``advice`` object, a name that is not short text, a step that is
        not a finite number > 0, more than `_MAX_ADVICE` entries.
    """
    obj = {"request": "advice", "assembly": assembly_to_json(req)}
    data = send(obj, _SLACK, int(req.n_steps))
    advice = data.get("advice")
    if not isinstance(advice, dict):
        raise AdapterOutputError(f"{who}: the answer to an advice request must hold 'advice', "
                                 "an object of name -> dt in s ({} for none)")  # fmt: skip
    if len(advice) > _MAX_ADVICE:
        raise AdapterOutputError(f"{who}: 'advice' holds {len(advice)} entries, at most "
                                 f"{_MAX_ADVICE}")  # fmt: skip
    out = {}
    for name, dt in advice.items():
        if not name or len(name) > _MAX_NAME or not name.isprintable():
            raise AdapterOutputError(f"{who}: advice name {name[:_MAX_NAME]!r} must be 1 to "
                                     f"{_MAX_NAME} printable characters")  # fmt: skip
        if isinstance(dt, bool) or not isinstance(dt, (int, float)) or not (0 < dt < math.inf):
            raise AdapterOutputError(f"{who}: 'advice.{name}' = {str(dt)[:40]!r} must be a "
                                     "finite step > 0 (s)")  # fmt: skip
        out[name] = float(dt)
    return out
