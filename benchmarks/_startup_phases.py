"""Where a warm ``hcv solve SCENE`` spends its CPU, phase by phase, in this one process.

Run by ``benchmarks/bench_startup.py`` in a new process per repeat (``python -m
benchmarks._startup_phases SCENE``); prints one JSON object: the CPU seconds (user +
system of this process, ``RUSAGE_SELF``) of each phase in the order the solve meets
them: ``import numpy``, ``import numba`` (numpy loaded), the package's modules the
command imports (``reference_impl.tasks``, the solve command, the scenes), ``import
scipy.linalg`` (numba's CPU target imports it to find BLAS), numba's target set-up (its
typing and lowering registries, loaded before its first compiled call, cached or not), the
command itself (``main(["solve", SCENE])``: the scene, the numba cache's loads and the
solve, the table printed to a discarded buffer), with the load of each compiled function
from numba's cache beside it, and ``total`` (everything this process spent up to its
end, Python's start included). What the interpreter spends after that, at exit, is
the parent's figure (the child's CPU from outside) minus ``total``; the heap is frozen
first where the command's own process freezes it (`reference_impl.cli._FROZEN_AT_EXIT`).
"""

from __future__ import annotations

import contextlib
import gc
import io
import json
import resource
import sys

from reference_impl.cli import _FROZEN_AT_EXIT


def _cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def main(scene: str) -> dict:
    """The phases of ``hcv solve SCENE`` (CPU s), each compiled function's cache load."""
    phases: dict[str, float] = {}
    t = _cpu()
    phases["python start-up, reference_impl.cli"] = t
    import numpy  # noqa: F401

    phases["import numpy"] = _cpu() - t
    t = _cpu()
    import numba  # noqa: F401

    phases["import numba"] = _cpu() - t
    t = _cpu()
    import reference_impl.cli.solve  # noqa: F401
    import reference_impl.scenes._scene  # noqa: F401
    import reference_impl.tasks  # noqa: F401

    phases["package modules"] = _cpu() - t
    t = _cpu()
    import scipy.linalg.cython_blas  # noqa: F401

    phases["import scipy.linalg (numba's BLAS check)"] = _cpu() - t
    from numba.core import dispatcher
    from numba.core.registry import cpu_target

    t = _cpu()
    cpu_target.target_context.refresh()
    cpu_target.typing_context.refresh()
    phases["numba target set-up (registries)"] = _cpu() - t

    loads: dict[str, float] = {}
    first_call = dispatcher.Dispatcher._compile_for_args

    def timed(self, *args, **kws):  # a compiled function's first call: its cache load
        t0 = _cpu()
        try:
            return first_call(self, *args, **kws)
        finally:
            name = f"{self.py_func.__module__}.{self.py_func.__qualname__}"
            loads[name] = loads.get(name, 0.0) + _cpu() - t0

    dispatcher.Dispatcher._compile_for_args = timed
    from reference_impl.cli import main as hcv

    t = _cpu()
    with contextlib.redirect_stdout(io.StringIO()):
        code = hcv(["solve", scene])
    phases["hcv solve (scene, cache loads, solve, table)"] = _cpu() - t
    if code != 0:
        raise SystemExit(f"hcv solve {scene} exited {code}")
    if "solve" in _FROZEN_AT_EXIT:  # the process ends as the command's own does
        gc.freeze()
    return {"scene": scene, "phases": phases, "cache_loads": loads, "total": _cpu()}


if __name__ == "__main__":
    print(json.dumps(main(sys.argv[1])))
