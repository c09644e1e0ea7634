"""A small third-party "contact code" for the adapter tests, in both forms of the contract.

As a program (the subprocess protocol, docs/adapter-protocol.md)::

    python verification/_adapter_script.py [--mode MODE] [--above V0] [--daemon SECONDS]

reads one JSON request on stdin and writes the trajectory on stdout, using
nothing but the standard library (velocity Verlet of U' = k q^p with the
universal damping law, as the contract describes). ``--mode`` makes it
misbehave for speeds above ``--above`` (default: always): ``hang`` (sleeps),
``crash`` (prints to stderr, exits 3), ``abort`` (SIGABRT), ``garbage`` (not
JSON), ``malformed`` (arrays of different lengths), ``error`` (reports an
error), ``tsuji`` (declares an implemented law with half the damping ratio,
and integrates it), ``decline`` (answers ``{"unsupported": ...}``), ``flood``
(writes to stdout without end), ``flipq``, ``flipv``, ``flipf`` (report the
overlap, its rate or the force with the wrong sign). ``--daemon S`` leaves
``sleep S`` running in a new session at every run (an adapter that daemonises,
escaping the process-group kill). It declines "sustained"
requests (it has no two-walls model), as the protocol lets a code do.

As Python adapters (run isolated in a worker by the benchmark): `ScriptAdapter`
(the same integrator), `CrashAdapter`, `HangAdapter`, `MalformedAdapter`,
`ChattyAdapter` (prints to stdout, against the contract). They
are defined only when the file is imported, so that the program starts without
importing the package (numpy, scipy).
"""

from __future__ import annotations

import json
import math
import os
import sys
import time


def integrate(scene: dict, zeta_scale: float = 1.0) -> dict:
    """Velocity Verlet from contact onset to the first step after separation."""
    pot = scene["potential"]
    if pot.get("family") != "power":
        raise ValueError(f"only power-law potentials, got {pot.get('family')!r}")
    k, p = float(pot["k"]), float(pot["p"])
    m, v0, dt, n_max = scene["mass"], scene["v0"], scene["dt"], int(scene["n_steps"])
    zeta = scene["damping"]["zeta"] * zeta_scale if scene["damping"]["law"] == "universal" else 0.0
    c = 2.0 * zeta * math.sqrt(m)
    t, q, v, f = [0.0], [0.0], [v0], [0.0]
    y, vel, force, touched = 0.0, v0, 0.0, False
    for n in range(1, n_max + 1):
        vh = vel - 0.5 * dt * force / m
        y += dt * vh
        force = 0.0
        if y > 0:
            fe = k * y**p
            u = k * y ** (p + 1) / (p + 1)
            force = fe + c * fe / math.sqrt(2.0 * u) * vh
            touched = True
        vel = vh - 0.5 * dt * force / m
        t.append(n * dt)
        q.append(y)
        v.append(vel)
        f.append(force)
        if touched and y <= 0:
            break
    return {"t": t, "q": q, "v": v, "force": f, "meta": {"code": "adapter-script 1.0"}}


def _misbehave(mode: str) -> None:
    if mode == "hang":
        time.sleep(3600)
    if mode == "crash":
        print("adapter-script: simulated crash in the contact kernel", file=sys.stderr)
        sys.exit(3)
    if mode == "abort":
        print("adapter-script: about to abort", file=sys.stderr, flush=True)
        os.abort()


def main(argv: list[str]) -> int:
    mode, above = "ok", -math.inf
    args = list(argv)
    while args:
        a = args.pop(0)
        if a == "--mode":
            mode = args.pop(0)
        elif a == "--above":
            above = float(args.pop(0))
        elif a == "--daemon":  # leave a process in its own session behind (escapes killpg)
            import subprocess

            subprocess.Popen(
                ["sleep", args.pop(0)],
                start_new_session=True,
                stdin=subprocess.DEVNULL,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
            )
    request = json.load(sys.stdin)
    scene = request["scene"]
    if request["request"] != "impact":
        json.dump({"unsupported": "adapter-script has no two-walls model"}, sys.stdout)
        return 0
    if scene["damping"]["law"] not in ("none", "universal"):  # protocol 2: any law is sent
        law = scene["damping"]["law"]
        json.dump({"unsupported": f"adapter-script integrates the universal law, not {law!r}"},
                  sys.stdout)  # fmt: skip
        return 0
    active = scene["v0"] > above
    if active:
        _misbehave(mode)
        if mode == "garbage":
            sys.stdout.write("this is not JSON\n")
            return 0
        if mode == "error":
            json.dump({"error": "mesh generation failed"}, sys.stdout)
            return 0
        if mode == "decline":
            json.dump({"unsupported": "no model for this scene"}, sys.stdout)
            return 0
        if mode == "flood":
            while True:
                sys.stdout.write("[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0]\n" * 1000)
    if mode == "tsuji" and active:
        out = integrate(scene, zeta_scale=0.5)
        out["implemented_law"] = {
            "potential": scene["potential"],
            "mass": scene["mass"],
            "damping": {"law": "universal", "zeta": 0.5 * scene["damping"]["zeta"]},
            "description": "half the damping ratio",
        }
    else:
        out = integrate(scene)
    if mode == "malformed" and active:
        out["force"] = out["force"][:-1]
    flip = {"flipq": "q", "flipv": "v", "flipf": "force"}.get(mode)
    if flip and active:
        out[flip] = [-x for x in out[flip]]
    json.dump(out, sys.stdout)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
else:  # imported: the Python adapters (the program itself needs only the standard library)
    from reference_impl.adapters.base import ContactAdapter

    class ScriptAdapter(ContactAdapter):
        """The script's integrator as a Python adapter."""

        name = "script"

        def _impact_impl(self, scene):
            return integrate(scene.to_json())

    class CrashAdapter(ScriptAdapter):
        """Dies (os._exit) for v0 > 1 m/s, after a line on stderr."""

        name = "crash"

        def _impact_impl(self, scene):
            if scene.v0 > 1.0:
                print("crash-adapter: segfault in the contact kernel", file=sys.stderr, flush=True)
                os._exit(139)
            return super()._impact_impl(scene)

    class HangAdapter(ScriptAdapter):
        """Never returns for v0 > 1 m/s."""

        name = "hang"

        def _impact_impl(self, scene):
            if scene.v0 > 1.0:
                print("hang-adapter: waiting forever", file=sys.stderr, flush=True)
                time.sleep(3600)
            return super()._impact_impl(scene)

    class ChattyAdapter(ScriptAdapter):
        """Prints a progress line on stdout for every run (the contract asks for stderr)."""

        name = "chatty"

        def _impact_impl(self, scene):
            print(f"chatty-adapter: running v0 = {scene.v0}", flush=True)
            return super()._impact_impl(scene)

    class FloodAdapter(ScriptAdapter):
        """Writes to stderr without end for v0 > 1 m/s."""

        name = "flood"

        def _impact_impl(self, scene):
            if scene.v0 > 1.0:
                line = "flood-adapter: " + "x" * 1000 + "\n"
                while True:
                    sys.stderr.write(line * 100)
            return super()._impact_impl(scene)

    class MalformedAdapter(ScriptAdapter):
        """Returns arrays of different lengths for v0 > 1 m/s."""

        name = "malformed"

        def _impact_impl(self, scene):
            out = super()._impact_impl(scene)
            if scene.v0 > 1.0:
                out["q"] = out["q"][:-2]
            return out
