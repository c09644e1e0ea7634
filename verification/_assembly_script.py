"""A DEM code of chains and lattices for the ``cmd:`` assembly tests (issue 39 §4).

    python verification/_assembly_script.py [--persistent] [--mode MODE] [--advice-scale S]

answers the assembly requests of the adapter protocol (``docs/adapter-protocol.md``,
"Assembly scenes from any language"): velocity Verlet of U'(q) = k q^p on every contact
of a chain on the x axis (sphere-sphere 2 R - (x_j - x_i), walls R minus the distance to
their plane) or of a periodic lattice (q = 2 R - |x_j + s - x_i| along the actual line of
centres), with numpy and nothing of the suite (a third party's code). It records every
step and ends a run past the request's ``stop_energy`` (kinetic energy, J) or when it
blows up. ``"advice"`` requests get one advice, ``quarter-crossing`` = S R / (4 max |v|)
(S from ``--advice-scale``, default 1). ``--persistent`` serves one JSON line per
request; otherwise one request on stdin, one answer on stdout.

``--mode`` makes its assembly answers hostile: ``shape`` (one body too few), ``nan-start``
(the first sample null), ``short`` (the first 10 steps only), ``text`` (a position as a
string), ``dt`` (t of a step 1 % longer), ``unsupported`` (declines, on two lines),
``error`` (reports an error), ``brackets`` (100 000 empty lists in its meta: parsed,
each costs 20 times its text), ``crash`` (20 kB of log on stderr, exit 3), ``hang``
(sleeps), ``no-id`` (persistent: no id), ``twice`` (persistent: every answer written
twice), ``bad-advice`` (advice of -1 s).
"""

from __future__ import annotations

import json
import math
import sys
import time

import numpy as np


def _chain_force(x, k, p, R, walls):
    f = np.zeros_like(x)
    q = 2.0 * R - np.diff(x)
    fc = np.where(q > 0, k * np.maximum(q, 0.0) ** p, 0.0)
    f[:-1] -= fc
    f[1:] += fc
    for w in walls:
        side = -1.0 if w["side"] == "left" else 1.0
        i = 0 if side < 0 else -1
        qw = R - side * (w["x"] - x[i])
        f[i] -= side * (k * qw**p if qw > 0 else 0.0)
    return f


def _lattice_force(x, k, p, R, i, j, shifts):
    d = x[j] + shifts - x[i]
    r = np.sqrt(np.sum(d * d, axis=1))
    q = 2.0 * R - r
    fc = np.where(q > 0, k * np.maximum(q, 0.0) ** p, 0.0)[:, None] * d / r[:, None]
    f = np.zeros_like(x)
    np.add.at(f, i, -fc)  # repulsive: i pushed away from j
    np.add.at(f, j, fc)
    return f


def run(a: dict) -> dict:
    """Velocity Verlet of the request's assembly: t, x, v of every step."""
    pot = a["potential"]
    if pot.get("family") != "power":
        return {"unsupported": f"only power-law contacts, got {pot.get('family')!r}"}
    k, p, R = float(pot["k"]), float(pot["p"]), float(a["radii"][0])
    m = np.asarray(a["masses"], dtype=float)
    x = np.asarray(a["positions"], dtype=float)
    v = np.asarray(a["velocities"], dtype=float)
    if a["kind"] == "chain":
        walls = a["walls"]

        def force(x):
            return _chain_force(x, k, p, R, walls)

        mm = m
    else:
        c = np.asarray(a["contacts"], dtype=np.int64).reshape(-1, 2)
        shifts = np.asarray(a["shifts"], dtype=float).reshape(-1, 3)

        def force(x):
            return _lattice_force(x, k, p, R, c[:, 0], c[:, 1], shifts)

        mm = m[:, None]
    dt, stop = float(a["dt"]), a["stop_energy"]
    stop = math.inf if stop is None else float(stop)
    xs, vs = [x.copy()], [v.copy()]
    acc = force(x) / mm
    with np.errstate(all="ignore"):  # a runaway overflows: a result, not an error
        for _ in range(int(a["n_steps"])):
            half = v + 0.5 * dt * acc
            x = x + dt * half
            acc = force(x) / mm
            v = half + 0.5 * dt * acc
            xs.append(x.copy())
            vs.append(v.copy())
            if not (np.all(np.isfinite(x)) and np.all(np.isfinite(v))):
                break
            if 0.5 * float(np.sum(mm * v * v)) > stop:
                break
    xs, vs = np.array(xs), np.array(vs)
    return {"t": [i * dt for i in range(len(xs))], "x": _json(xs), "v": _json(vs),
            "meta": {"code": "assembly-script 1.0"}}  # fmt: skip


def _json(a: np.ndarray) -> list:
    """Nested lists, non-finite numbers as None (JSON null)."""
    if np.all(np.isfinite(a)):
        return a.tolist()
    return np.where(np.isfinite(a), a, None).tolist()


def answer(req: dict, mode: str, advice_scale: float) -> dict:
    a = req["assembly"]
    if req["request"] == "advice":
        if mode == "bad-advice":
            return {"advice": {"quarter-crossing": -1.0}}
        vmax = float(np.max(np.abs(np.asarray(a["velocities"], dtype=float))))
        return {"advice": {"quarter-crossing": advice_scale * 0.25 * a["radii"][0] / vmax}}
    if mode == "unsupported":
        return {"unsupported": "this code runs no such scene\nsecond line"}
    if mode == "error":
        return {"error": "lost a body in the neighbour list"}
    if mode == "crash":
        sys.stderr.write("a log line of the contact search\n" * 700)
        sys.stderr.write("assembly-script: segmentation fault (simulated)\n")
        sys.stderr.flush()
        sys.exit(3)
    if mode == "hang":
        time.sleep(3600)
    out = run(a)
    if mode == "shape":
        out["x"] = [row[:-1] for row in out["x"]]
    elif mode == "nan-start":
        out["x"][0] = [None] * len(out["x"][0])
    elif mode == "short":
        out = {key: out[key][:11] for key in ("t", "x", "v")}
    elif mode == "text":
        out["x"][1][0] = str(out["x"][1][0])
    elif mode == "dt":
        out["t"] = [1.01 * t for t in out["t"]]
    elif mode == "brackets":
        out["meta"]["junk"] = [[]] * 100_000
    return out


def main(argv: list[str]) -> int:
    mode, persistent, scale = "ok", False, 1.0
    args = list(argv)
    while args:
        flag = args.pop(0)
        if flag == "--mode":
            mode = args.pop(0)
        elif flag == "--persistent":
            persistent = True
        elif flag == "--advice-scale":
            scale = float(args.pop(0))
    if not persistent:
        sys.stdout.write(json.dumps(answer(json.load(sys.stdin), mode, scale)))
        return 0
    for line in sys.stdin:
        req = json.loads(line)
        out = answer(req, mode, scale)
        if mode != "no-id":
            out["id"] = req["id"]
        text = json.dumps(out) + "\n"
        sys.stdout.write(text * (2 if mode == "twice" else 1))
        sys.stdout.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
