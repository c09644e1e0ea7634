"""``hcv dt-crit SCENE --adapter CODE``: a code's Delta t_crit on a chain or lattice, its advice.

Issue 39 section 4: the code runs the chain scene (contract item 14 of
`reference_impl.adapters.base`), the suite's search and criterion measure its critical
step (`reference_impl.bench.assembly_codes.code_report`), and the code's own step advice
gets a verdict. Loaded only when ``--adapter`` is given (it loads the codes' adapters).
A code that does not run assembly scenes, a scene that is neither a chain nor a lattice the
codes run (`reference_impl.bench.assembly_codes.lattice_request`: periodic, rectangular
box, normal contacts only), or a code that declines the scene is one line and exit
status 2; a code that fails (an error, malformed output, a crash) is one line naming it
and exit status 1; a run of the code that outlives ``--timeout`` (default `RUN_TIMEOUT_S`)
is killed, and hcv stops with one line "... timed out after N s" and exit status 2. The code's runs go through `reference_impl.bench._code_worker`: in a
worker process of the bench where the adapter asks for isolation, as ``hcv bench`` runs
it, so that a segfault or an abort of the code ends that worker, not hcv.
"""

from __future__ import annotations

import json
import sys

from reference_impl.adapters.base import AdapterDeclined, AdapterError
from reference_impl.bench._code_worker import RUN_TIMEOUT_S, open_code
from reference_impl.bench.assembly_codes import CODE_HORIZON, code_report, lattice_request
from reference_impl.cli._run import EXIT_FAIL, EXIT_OK
from reference_impl.cli._tables import fmt
from reference_impl.errors import HCVInputError

__all__ = ["run_code"]


def run_code(args, scene, horizons: list[int] | None, timeout: float | None = None) -> int:
    """Run ``args.adapter`` on the chain or lattice ``scene`` at one horizon and print the verdicts.

    Parameters
    ----------
    args : argparse.Namespace
        ``adapter`` (a registry spec), ``json``.
    scene : AssemblyScene
        The scene named (a chain or a lattice the codes run; anything else is refused).
    horizons : list of int or None
        ``--horizons`` parsed: one value, or None for `CODE_HORIZON`.
    timeout : float or None
        ``--timeout`` parsed: seconds allowed for each run of the code (None:
        `RUN_TIMEOUT_S`); the code's process is killed at it.

    Raises
    ------
    HCVInputError
        One line: no chain or runnable lattice, more than one horizon, the code declines,
        a run of the code timed out (its process killed).
    """
    if scene.kind not in ("chain", "lattice"):
        raise HCVInputError(
            f"--adapter runs chain and lattice scenes only; scene {scene.name!r} is a {scene.kind}"
        )
    if scene.kind == "lattice":  # refused before any code starts (skewed box, tangential, ...)
        lattice_request(scene, 1.0, 1)
    horizons = horizons or [CODE_HORIZON]
    if len(horizons) != 1:
        raise HCVInputError(f"--adapter takes one horizon, got --horizons {horizons!r}")
    limit = RUN_TIMEOUT_S if timeout is None else timeout
    # a worker process where the code asks for isolation, killed at the limit
    adapter = open_code(args.adapter, limit)
    try:
        if not adapter.supports_assembly:
            raise HCVInputError(f"{adapter.label} does not run assembly scenes")
        try:
            rep = code_report(adapter, scene, horizons[0])
        except AdapterDeclined as exc:
            raise HCVInputError(exc.declined) from None
        except AdapterError as exc:  # the code failed (error, bad output, crash): not the input
            if getattr(exc, "timed_out", False):  # a run outlived its limit, its process killed
                # the limit the run had: a cmd: spec's own timeout= wins over --timeout
                took = getattr(adapter, "timeout", limit)
                raise HCVInputError(
                    f"{adapter.label} timed out after {took:g} s (a run of the code; its "
                    "process was killed); --timeout SECONDS allows more"
                ) from None
            print(f"hcv: error: {adapter.label} failed: {' '.join(str(exc).split())}",
                  file=sys.stderr)  # fmt: skip
            return EXIT_FAIL
    finally:
        adapter.close()
    if args.json:
        json.dump({"scene": scene.to_dict(), "code": rep}, sys.stdout, indent=2, default=str)
        sys.stdout.write("\n")
        return EXIT_OK
    print(
        f"dt-crit: {scene.name} in {rep['code']} ({rep['n_bodies']} bodies, "
        f"{rep['horizon']} steps, {rep['runs']} runs, {fmt(rep['wall_s'])} s)"
    )
    print(f"  dt_safe (paper) [s]: {fmt(rep['dt_safe'])}")
    print(
        f"  measured dt_crit (smallest failing) [s]: {fmt(rep['dt_crit'])} "
        f"({rep['evidence']}); the suite's: {fmt(rep['dt_crit_suite'])}"
    )
    for a in rep["advice"]:
        verdict = "safe" if a["safe"] else "NOT safe"
        print(
            f"  advice {a['name']} [s]: {fmt(a['dt'])}: {verdict}, "
            f"dt_crit / advice = {fmt(a['factor'])}"
        )
    if not rep["advice"]:
        print(f"  advice: none ({rep['advice_note']})")
    return EXIT_OK
