"""A persistent-mode contact code for the tests (``cmd[persistent=true]:...``, issue 28).

    python verification/_persistent_script.py [--banner] [--hang-above V0]
                                              [--die-after N] [--no-id]
                                              [--stderr-bytes N]

serves requests of the adapter protocol, one JSON line each on stdin, one JSON
answer line each on stdout, with the integrator of `_adapter_script` (velocity
Verlet of the universal law). The answer's ``meta`` carries the process id and
the options it received. ``--banner`` prints two non-JSON lines first (as YADE's
launcher does); ``--hang-above V0`` never answers a request faster than V0;
``--die-after N`` exits (status 7) right after its N-th answer, i.e. between
requests; ``--no-id`` answers without the request's id (a protocol error);
``--stderr-bytes N`` writes N bytes of log lines to stderr before each answer, the
last one ``end of the log of answer K`` (K counts from 1).
Option ``zeta_scale`` (in the request's ``"options"``) scales the damping ratio
it integrates and declares: what the calibration test searches.
"""

from __future__ import annotations

import ast
import json
import math
import os
import sys
import time


def _load_integrate():
    """`_adapter_script.integrate` alone: importing that module as a library would import
    the package (numpy, scipy: ~1 s per start), which a persistent server must not need."""
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "_adapter_script.py")
    with open(path) as fh:
        tree = ast.parse(fh.read(), path)
    fn = next(n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == "integrate")
    namespace = {"math": math}
    exec(compile(ast.Module([fn], type_ignores=[]), path, "exec"), namespace)
    return namespace["integrate"]


integrate = _load_integrate()


def main(argv: list[str]) -> int:
    hang_above, die_after, banner, no_id = float("inf"), None, False, False
    stderr_bytes = 0
    args = list(argv)
    while args:
        a = args.pop(0)
        if a == "--hang-above":
            hang_above = float(args.pop(0))
        elif a == "--die-after":
            die_after = int(args.pop(0))
        elif a == "--banner":
            banner = True
        elif a == "--no-id":
            no_id = True
        elif a == "--stderr-bytes":
            stderr_bytes = int(args.pop(0))
    if banner:
        print("Welcome to a contact code 1.0", flush=True)
        print("listening on nothing", flush=True)
    answered = 0
    for line in sys.stdin:
        req = json.loads(line)
        scene, options = req["scene"], req.get("options", {})
        unknown = sorted(set(options) - {"zeta_scale"})
        if unknown:
            out = {"error": f"unknown option {unknown[0]}"}
        elif scene["v0"] > hang_above:
            time.sleep(3600)
        else:
            scale = float(options.get("zeta_scale", 1.0))
            out = integrate(scene, zeta_scale=scale)
            out["meta"].update(pid=os.getpid(), options=options)
            if scene["damping"]["law"] == "universal":
                out["implemented_law"] = {
                    "damping": {"law": "universal", "zeta": scale * scene["damping"]["zeta"]}
                }
        if not no_id:
            out["id"] = req["id"]
        if stderr_bytes:
            line = "a log line of a code that never stops logging\n"
            sys.stderr.write(line * (stderr_bytes // len(line)))
            sys.stderr.write(f"end of the log of answer {answered + 1}\n")
            sys.stderr.flush()
        sys.stdout.write(json.dumps(out) + "\n")
        sys.stdout.flush()
        answered += 1
        if die_after is not None and answered >= die_after:
            return 7
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
