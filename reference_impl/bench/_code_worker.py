"""A code's assembly runs, isolated as ``hcv bench`` isolates its runs (issue 39 section 4).

``hcv dt-crit SCENE --adapter CODE`` (and the codes' table of the report) make a code run
tens of chains or lattices (contract item 14). A code that asks for isolation
(`ContactAdapter.isolate`: LAMMPS and LIGGGHTS, and third-party Python code by default)
runs them here in a worker process of the bench (`reference_impl.bench.worker.WorkerExecutor`),
the one ``hcv bench`` runs it in: a crash of the code (a segfault in its C library, an
abort, ``os._exit``) ends the worker, not the caller, and fails the call as one
`AdapterRunError` saying how the worker died ("crashed (killed by signal 11, SIGSEGV)").
A code that is trusted or isolated in its own way (the reference; YADE, a program
behind a pipe) runs in-process as before.

**Timeout.** Each run of the code (one chain or lattice, or its step advice) has
``timeout`` seconds (default `RUN_TIMEOUT_S`, ``hcv dt-crit --timeout``): a worker that has
not answered by then is killed, and the call fails as one `AdapterTimeout` ("timed out after
N s"). A code behind a pipe that declares ``timeout_given`` (``cmd:``, YADE) gets the same
limit unless its spec set its own, as ``hcv bench`` gives it the bench's per-run timeout;
its own timeout kills its process. A code that runs in-process with neither (the
reference) bounds its runs itself.
"""

from __future__ import annotations

from reference_impl.adapters.base import AdapterDeclined, AdapterRunError
from reference_impl.adapters.registry import get_adapter
from reference_impl.adapters.subprocess import AdapterTimeout
from reference_impl.bench.worker import WorkerExecutor

__all__ = ["RUN_TIMEOUT_S", "open_code"]

# Seconds allowed for one run of a code, as ``hcv bench`` allows one ([run] timeout of
# `reference_impl/bench/scorecard/tolerances.toml`; verification/test_assembly_codes.py
# holds them equal): a chain of ten bodies over the default 2000 steps takes well under a
# second in every built-in code, a LAMMPS start-up included.
RUN_TIMEOUT_S = 60.0


class _WorkerCode:
    """The assembly side of an adapter whose calls run in a bench worker process.

    It answers what `reference_impl.bench.assembly_codes` asks of a code (``name``,
    ``label``, ``supports_assembly``, ``supports_lattice``, ``assembly``,
    ``step_advice``, ``close``); the worker builds the adapter from the same spec and
    runs the adapter itself (not one of its variants); each call has ``timeout`` seconds,
    after which the worker process is killed.
    """

    def __init__(self, executor: WorkerExecutor, timeout: float):
        self._executor = executor
        self.timeout = timeout
        parent = executor.adapter  # the parent-side copy: names and flags, it runs nothing
        self.name, self.label = parent.name, parent.label
        self.supports_assembly = parent.supports_assembly
        self.supports_lattice = parent.supports_lattice

    def _call(self, method: str, request):
        out = self._executor.call(None, method, request, timeout=self.timeout)
        if out.ok:
            return out.value
        if out.timed_out:  # the executor has killed the worker; the next call starts one
            raise AdapterTimeout(
                f"{self.label}: a run timed out after {self.timeout:g} s; its worker process "
                "was killed",
                out.stderr,
            )
        if out.declined:  # a decline stays one: the caller's input, not the code's failure
            raise AdapterDeclined(out.declined)
        raise AdapterRunError(out.error, out.stderr)

    def assembly(self, request):
        """The code's validated run of ``request`` (a `ChainRun` or `LatticeRun`).

        Raises
        ------
        AdapterDeclined
            The code declines the request.
        AdapterRunError
            The code raised, returned malformed output or its worker died (one line);
            `AdapterTimeout` when the run outlived the timeout (the worker killed).
        """
        return self._call("assembly", request)

    def step_advice(self, request) -> dict:
        """The code's step advice (s) for ``request``; the errors of `assembly`."""
        return self._call("step_advice", request)

    def close(self) -> None:
        """End the worker process and remove its output files."""
        self._executor.close()

    def __repr__(self) -> str:
        return f"<isolated {self.label}>"


def open_code(spec: str, timeout: float = RUN_TIMEOUT_S):
    """The code named by ``spec``, ready for assembly runs, isolated as the gate isolates it.

    Parameters
    ----------
    spec : str
        An adapter spec (a registry name, ``module:Class``, ...).
    timeout : float
        Seconds allowed for each run (s, finite, > 0; the caller checks it): the worker is
        killed after it; a ``cmd:`` or YADE code whose spec set no timeout of its own
        gets it as its own.

    Returns
    -------
    ContactAdapter or _WorkerCode
        The adapter itself where it does not ask for isolation; else its assembly calls
        through a worker process (started at the first call). Close it after use.

    Raises
    ------
    HCVInputError
        The spec names no code, or the code is not installed (one line).
    """
    adapter = get_adapter(spec)
    if not adapter.isolate:
        # as hcv bench gives such a code its per-run timeout (scorecard.runner)
        if getattr(adapter, "timeout_given", True) is False:
            adapter.timeout = float(timeout)
        return adapter
    adapter.close()
    return _WorkerCode(WorkerExecutor(spec), float(timeout))
