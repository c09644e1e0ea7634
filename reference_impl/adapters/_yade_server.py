"""The YADE side of the yade adapter: a script run by the ``yade`` launcher, never imported.

``yade -n -x _yade_server.py`` runs it inside YADE's own Python (which has neither
this package nor its dependencies, so it imports only the standard library and
yade). It serves requests, one JSON object per line on stdin, one JSON answer
per line on stdout, until stdin closes (the persistent mode of the adapter
protocol, see `reference_impl.adapters._persistent`):

* ``{"id": n, "op": "impact", "scene": {...}, "dt": s, "n_steps": N, "v0": m/s}``
  -> ``{"id": n, "q": [...], "v": [...], "f": [...], "phys": {...}}``: the state
  after each step (q from the positions, v = -dq/dt read from the bodies'
  velocities, f the force of that step), stopping at the first sample back out
  of contact; sample 0 is the onset (q = 0, v0, no force).
* ``{"id": n, "op": "probe", "scene": {...}, "states": [[q, dq/dt], ...]}``
  -> ``{"id": n, "f": [...], "phys": {...}}``: the force YADE computes with the
  body placed at each state (one step from it).
* ``{"id": n, "op": "chain", "scene": {...}, "dt": s, "n_steps": N}`` -> ``{"id": n,
  "x": [[...], ...], "v": [[...], ...]}``: a chain of spheres on the x axis (contract item
  14, `_assembly`), positions and velocities after each step; ``"op": "chain_advice"``
  -> ``{"pwave": s, "gst": s, "gst_steps": n}``: ``utils.PWaveTimeStep()`` and the
  smallest step ``GlobalStiffnessTimeStepper`` chose along a run it drove
  (`_assembly_advice`).
* ``"op": "lattice"`` and ``"lattice_advice"``: the same for a periodic lattice (the scene
  has a ``cell``; ``x`` and ``v`` per step are [x, y, z] per body). One builder
  (`_build_assembly`) sets both up.
* anything that fails -> ``{"id": n, "error": "one line"}``; the server goes on.

Traps this script avoids (found by maintainers wiring YADE by hand):

* the launcher prints a banner (and the XML-RPC / TCP prompt lines) on stdout
  before the script runs: the adapter skips stdout lines that are not JSON
  objects, and this script answers on a duplicate of the original stdout while
  file descriptor 1 goes to stderr (nothing YADE prints can corrupt an answer);
* the launcher reads its own global ``opts`` when it exits: a script global of
  that name makes the exit crash, so this script keeps everything in functions;
* ``NewtonIntegrator`` applies a numerical damping of 0.2 unless told
  ``damping=0``: it is set to 0 here.
"""

import json
import math
import os
import sys


def _build(sc, delta, rate):
    """Reset YADE to one contact at overlap delta (m) and dq/dt = rate (m/s)."""
    from yade import O, utils
    from yade.wrapper import (
        Bo1_Sphere_Aabb,
        Bo1_Wall_Aabb,
        ForceResetter,
        FrictMat,
        Ig2_Sphere_Sphere_ScGeom,
        Ig2_Wall_Sphere_ScGeom,
        InsertionSortCollider,
        InteractionLoop,
        Ip2_FrictMat_FrictMat_MindlinPhys,
        Ip2_ViscElMat_ViscElMat_ViscElPhys,
        Law2_ScGeom_MindlinPhys_Mindlin,
        Law2_ScGeom_ViscElPhys_Basic,
        MatchMaker,
        NewtonIntegrator,
        ViscElMat,
    )

    O.reset()
    radius = float(sc["R"])
    if sc["law"] == "mindlin":
        mat = FrictMat(young=sc["young"], poisson=0.0, frictionAngle=0.0, density=1.0)
        key, value = sc["ip2"]
        ip2 = Ip2_FrictMat_FrictMat_MindlinPhys(**{key: MatchMaker(matches=((0, 0, value),))})
        law2 = Law2_ScGeom_MindlinPhys_Mindlin()
    else:
        mat = ViscElMat(frictionAngle=0.0, density=1.0, **sc["material"])
        ip2 = Ip2_ViscElMat_ViscElMat_ViscElPhys()
        law2 = Law2_ScGeom_ViscElPhys_Basic()
    mid = O.materials.append(mat)
    if sc["geometry"] == "wall":
        O.bodies.append(utils.wall(0.0, axis=2, sense=0, material=mid))
        sph = utils.sphere((0.0, 0.0, radius - delta), radius, material=mid)
        O.bodies.append(sph)
        sph.state.mass = float(sc["mass"])
        sph.state.vel = (0.0, 0.0, -rate)
    else:
        a = utils.sphere((0.0, 0.0, -radius + 0.5 * delta), radius, material=mid)
        b = utils.sphere((0.0, 0.0, radius - 0.5 * delta), radius, material=mid)
        O.bodies.append([a, b])
        for body, sign in ((a, 1.0), (b, -1.0)):
            body.state.mass = float(sc["mass"])
            body.state.vel = (0.0, 0.0, sign * 0.5 * rate)
    O.engines = [
        ForceResetter(),
        InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Wall_Aabb()], verletDist=0.0),
        InteractionLoop([Ig2_Sphere_Sphere_ScGeom(), Ig2_Wall_Sphere_ScGeom()], [ip2], [law2]),
        # damping=0: NewtonIntegrator's default 0.2 numerical damping would change the law
        NewtonIntegrator(damping=0.0, gravity=(0.0, 0.0, 0.0)),
    ]
    return O, radius


def _observe(O, sc, radius):
    """(q, -dq/dt as stored, force on the body, + repulsive) of the current state."""
    if sc["geometry"] == "wall":
        st = O.bodies[1].state
        return radius - st.pos[2], -st.vel[2], O.forces.f(1)[2]
    a, b = O.bodies[0].state, O.bodies[1].state
    return 2.0 * radius - (b.pos[2] - a.pos[2]), a.vel[2] - b.vel[2], O.forces.f(1)[2]


def _phys(O):
    out = {}
    for inter in O.interactions:
        for name in ("kn", "cn", "kno", "betan"):
            if hasattr(inter.phys, name):
                out[name] = float(getattr(inter.phys, name))
    return out


def _impact(req):
    sc = req["scene"]
    O, radius = _build(sc, 0.0, float(req["v0"]))
    O.dt = float(req["dt"])
    q, v, f = [0.0], [float(req["v0"])], [0.0]
    phys = {}
    touched = False
    for _ in range(int(req["n_steps"])):
        O.step()
        qi, vi, fi = _observe(O, sc, radius)
        q.append(qi)
        v.append(vi)
        f.append(fi)
        if not phys:
            phys = _phys(O)
        if not (math.isfinite(qi) and math.isfinite(vi)):
            break
        touched = touched or qi > 0.0
        if touched and qi <= 0.0:
            break
    return {"q": q, "v": v, "f": f, "phys": phys}


def _probe(req):
    sc = req["scene"]
    forces, phys = [], {}
    for delta, rate in req["states"]:
        O, _radius = _build(sc, float(delta), float(rate))
        O.dt = 1e-12  # one step computes the force at the placed state; the move is irrelevant
        O.step()
        forces.append(O.forces.f(1)[2])
        phys = _phys(O)
    return {"f": forces, "phys": phys}


# An assembly run ends after the first step whose kinetic energy exceeds the request's
# "stop" (J): the suite has decided a runaway by then (ChainRequest.stop_energy).


def _vector(a):
    """A position or velocity of the scene as (x, y, z): a chain's are numbers along x."""
    if isinstance(a, list):
        return tuple(float(c) for c in a)
    return (float(a), 0.0, 0.0)


def _build_assembly(sc, gst=None):
    """Reset YADE to the assembly of a request: a chain of spheres on x with its walls, or a
    periodic lattice (``sc["cell"]``); one material, no gravity, no damping."""
    from yade import O, utils
    from yade.wrapper import (
        Bo1_Sphere_Aabb,
        Bo1_Wall_Aabb,
        ForceResetter,
        FrictMat,
        Ig2_Sphere_Sphere_ScGeom,
        Ig2_Wall_Sphere_ScGeom,
        InsertionSortCollider,
        InteractionLoop,
        Ip2_FrictMat_FrictMat_MindlinPhys,
        Law2_ScGeom_MindlinPhys_Mindlin,
        NewtonIntegrator,
    )

    chain = "cell" not in sc
    O.reset()
    if not chain:
        O.periodic = True
        O.cell.setBox(*[float(b) for b in sc["cell"]])
    radius = float(sc["R"])
    mat = O.materials.append(
        FrictMat(young=sc["young"], poisson=0.0, frictionAngle=0.0, density=sc["density"])
    )
    for x, side in sc.get("walls", ()):
        O.bodies.append(utils.wall(float(x), axis=0, sense=-int(side), material=mat))
    ids = []
    for x, m, v in zip(sc["x0"], sc["masses"], sc["velocities"], strict=True):
        b = utils.sphere(_vector(x), radius, material=mat)
        ids.append(O.bodies.append(b))
        b.state.mass = float(m)  # the density gave it to round-off; the scene's exactly
        b.state.vel = _vector(v)
    # a chain's walls need their own bound and geometry functors; a lattice has none
    bounds = [Bo1_Sphere_Aabb(), Bo1_Wall_Aabb()] if chain else [Bo1_Sphere_Aabb()]
    geoms = [Ig2_Sphere_Sphere_ScGeom()] + ([Ig2_Wall_Sphere_ScGeom()] if chain else [])
    engines = [
        ForceResetter(),
        InsertionSortCollider(bounds, verletDist=0.0),
        InteractionLoop(
            geoms, [Ip2_FrictMat_FrictMat_MindlinPhys()], [Law2_ScGeom_MindlinPhys_Mindlin()]
        ),
    ]
    if gst is not None:
        engines.append(gst)
    # damping=0: NewtonIntegrator's default 0.2 numerical damping would change the law
    engines.append(NewtonIntegrator(damping=0.0, gravity=(0.0, 0.0, 0.0)))
    O.engines = engines
    return O, ids


def _assembly(req):
    """``chain`` and ``lattice``: positions and velocities after each step (a chain's along x,
    a lattice's [x, y, z] per body), up to the stop energy or a non-finite state."""
    sc = req["scene"]
    O, ids = _build_assembly(sc)
    O.dt = float(req["dt"])
    dims = 3 if "cell" in sc else 1  # a chain's bodies move along x only

    def read(vec):
        return [float(vec[c]) for c in range(dims)]

    masses = [float(m) for m in sc["masses"]]
    stop = float(req["stop"])
    xs = [[read(_vector(x)) for x in sc["x0"]]]
    vs = [[read(_vector(v)) for v in sc["velocities"]]]
    for _ in range(int(req["n_steps"])):
        O.step()
        x = [read(O.bodies[i].state.pos) for i in ids]
        v = [read(O.bodies[i].state.vel) for i in ids]
        ke = sum(0.5 * m * sum(a * a for a in u) for m, u in zip(masses, v, strict=True))
        xs.append(x)
        vs.append(v)
        if not all(math.isfinite(a) for row in x + v for a in row) or ke > stop:
            break
    if dims == 1:  # a chain answers a number per body
        xs, vs = ([[r[0] for r in row] for row in rows] for rows in (xs, vs))
    return {"x": xs, "v": vs}


def _assembly_advice(req):
    """``chain_advice`` and ``lattice_advice``: ``utils.PWaveTimeStep()`` of the assembly, and
    the smallest step ``GlobalStiffnessTimeStepper`` set along a run it drove."""
    from yade import utils
    from yade.wrapper import GlobalStiffnessTimeStepper

    sc = req["scene"]
    O, _ids = _build_assembly(sc)
    pwave = float(utils.PWaveTimeStep())
    # the stepper as a user adds it: active, its default safety coefficient, updating each
    # step; it sets O.dt itself, the smallest it set along the run is its advice
    gst = GlobalStiffnessTimeStepper(active=True, timeStepUpdateInterval=1,
                                     defaultDt=float(req["dt"]))  # fmt: skip
    O, _ids = _build_assembly(sc, gst)
    O.dt = float(req["dt"])
    chosen = []
    for _ in range(int(req["n_steps"])):
        O.step()
        if O.interactions.countReal():
            chosen.append(float(O.dt))
    return {
        "pwave": pwave,
        "gst": min(chosen) if chosen else None,
        "gst_steps": len(chosen),
        "gst_safety": float(gst.timestepSafetyCoefficient),
    }


def _finite(obj):
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    if isinstance(obj, list):
        return [_finite(x) for x in obj]
    if isinstance(obj, dict):
        return {k: _finite(x) for k, x in obj.items()}
    return obj


def main():
    out = os.fdopen(os.dup(1), "w")
    os.dup2(2, 1)  # whatever YADE prints from now on goes to stderr
    handlers = {"impact": _impact, "probe": _probe, "chain": _assembly, "lattice": _assembly,
                "chain_advice": _assembly_advice, "lattice_advice": _assembly_advice}  # fmt: skip
    for line in sys.stdin:
        if not line.strip():
            continue
        rid = None
        try:
            req = json.loads(line)
            rid = req.get("id")
            ans = handlers[req["op"]](req)
        except Exception as exc:  # one failed request, the server goes on
            ans = {"error": f"{type(exc).__name__}: {exc}".splitlines()[0][:300]}
        ans["id"] = rid
        out.write(json.dumps(_finite(ans)) + "\n")
        out.flush()


if __name__ == "__main__":  # the yade launcher runs a script as __main__
    main()
