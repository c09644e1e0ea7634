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
"""

from __future__ import annotations

from reference_impl.adapters.base import AdapterDeclined, AdapterRunError
from reference_impl.adapters.registry import get_adapter
from reference_impl.bench.worker import WorkerExecutor

__all__ = ["open_code"]


class _WorkerCode:
    """The assembly side of an adapter whose calls run in a bench worker process.

    It answers what `reference_impl.bench.assembly_codes` asks of a code (``name``,
    ``label``, ``supports_assembly``, ``supports_lattice``, ``assembly``,
    ``step_advice``, ``close``); the worker builds the adapter from the same spec and
    runs the adapter itself (not one of its variants), with no timeout of its own (the
    codes bound their runs, as in-process).
    """

    def __init__(self, executor: WorkerExecutor):
        self._executor = executor
        parent = executor.adapter  # the parent-side copy: names and flags, it runs nothing
        self.name, self.label = parent.name, parent.label
        self.supports_assembly = parent.supports_assembly
        self.supports_lattice = parent.supports_lattice

    def _call(self, method: str, request):
        out = self._executor.call(None, method, request)
        if out.ok:
            return out.value
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
            The code raised, returned malformed output or its worker died (one line).
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


def open_code(spec: str):
    """The code named by ``spec``, ready for assembly runs, isolated as the gate isolates it.

    Parameters
    ----------
    spec : str
        An adapter spec (a registry name, ``module:Class``, ...).

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
        return adapter
    adapter.close()
    return _WorkerCode(WorkerExecutor(spec))
