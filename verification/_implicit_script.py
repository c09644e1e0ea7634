"""A first-order implicit-Euler contact code as a ``cmd:`` program (issue 40 leftovers, a),
for verification/test_cmd_declaration.py.

    python verification/_implicit_script.py              # one request on stdin
    python verification/_implicit_script.py --persistent # one request per line

Backward Euler on a linear contact with the universal damping law (U' = k q, C =
2 zeta sqrt(m k), a constant dashpot for p = 1): q and v at the new step, the force at
the new state, the scheme of Drake's discrete modes. Each step solves the 2 x 2 linear
system in closed form (in contact) or flies freely (out of contact), the same root the
bench's own implicit Euler (`reference_impl.bench.scorecard._schemes`) finds by brentq.
It records at t_n the state and the law's force F(q_n, v_n). Standard library only, so a
start costs no numpy.

Option ``damping_scale`` (in the request's ``"options"``) multiplies the dashpot it
integrates and reports while the law it declares stays the scene's: a code 10 % too
damped is ``damping_scale = 1.1``; ``force_scale`` multiplies the force it reports (a
units bug: ``force_scale = 2``), not the one it integrates. Any other option is answered ``{"error": ...}``,
as the protocol asks. Scenes other than an impact on a ``power`` potential with p = 1
and the universal law (or none) read at the overlap end are declined.
"""

from __future__ import annotations

import json
import math
import sys


def integrate(scene: dict, damping_scale: float, force_scale: float = 1.0) -> dict:
    """The response (t, q, v, force) of one impact request's scene."""
    pot, damp = scene["potential"], scene["damping"]
    k, m, v0 = float(pot["k"]), float(scene["mass"]), float(scene["v0"])
    dt, n = float(scene["dt"]), int(scene["n_steps"])
    c = damping_scale * 2.0 * float(damp["zeta"]) * math.sqrt(m * k)

    def force(q, v):
        return k * q + c * v if q > 0.0 else 0.0

    t, q, v = [0.0], [0.0], [v0]
    for i in range(1, n + 1):
        qo, vo = q[-1], v[-1]
        # in contact: w (1 + dt c / m + dt^2 k / m) = vo - dt k qo / m, q' = qo + dt w
        w = (vo - dt * k * qo / m) / (1.0 + dt * c / m + dt * dt * k / m)
        if not qo + dt * w > 0.0:
            # out of contact F = 0: free flight w = vo when it stays out, else the root
            # sits at the force's jump, q' = 0
            w = vo if qo + dt * vo <= 0.0 else -qo / dt
        t.append(i * dt)
        q.append(qo + dt * w)
        v.append(w)
        if q[-1] <= 0.0:
            break
    reported = [force_scale * force(a, b) for a, b in zip(q, v, strict=True)]
    return {"t": t, "q": q, "v": v, "force": reported,
            "meta": {"code": "implicit-euler script"}}  # fmt: skip


def answer(request: dict) -> dict:
    """The response to one request: a trajectory, a decline or an error."""
    options = dict(request.get("options", {}))
    scale = options.pop("damping_scale", 1.0)
    force_scale = options.pop("force_scale", 1.0)
    if options:
        return {"error": f"unknown option {sorted(options)[0]}"}
    scene = request["scene"]
    pot, damp = scene["potential"], scene["damping"]
    if request.get("request") != "impact" or scene.get("kind") != "impact":
        return {"unsupported": "single impacts only"}
    if pot.get("family") != "power" or pot.get("p") != 1:
        return {"unsupported": "a linear (p = 1) power contact only"}
    if damp.get("law") not in ("universal", "none") or damp.get("restitution_end") != "overlap":
        return {"unsupported": "the universal law read at the overlap end only"}
    return integrate(scene, float(scale), float(force_scale))


def main(argv: list[str]) -> int:
    if "--persistent" in argv:
        for line in sys.stdin:
            req = json.loads(line)
            out = answer(req)
            out["id"] = req["id"]
            sys.stdout.write(json.dumps(out) + "\n")
            sys.stdout.flush()
        return 0
    sys.stdout.write(json.dumps(answer(json.load(sys.stdin))))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
