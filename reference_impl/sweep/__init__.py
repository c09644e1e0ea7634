"""Parameter sweeps on Dask: the `run_cases` engine (``hcv sweep`` is `reference_impl.cli.sweep`).

A sweep spec (TOML: ``task``, a ``[scene]``, a ``[sweep]`` table of dotted paths
to lists) expands into the Cartesian product of cases (`load_spec`); each case
is a pure task keyed by a hash of its parameters, run on a local cluster of
processes or an existing Dask scheduler (`run_cases`; `reference_impl.cli.sweep.run_sweep`
runs a whole spec). Dask is the
``sweep`` extra; `run_cases` falls back to serial in-process runs without it.
"""

from reference_impl.sweep._map import dt_crit_map_on_cluster
from reference_impl.sweep._runner import (
    CaseFailed,
    Outcome,
    dask_available,
    iter_outcomes,
    open_client,
    run_cases,
)
from reference_impl.sweep._spec import (
    DEFAULT_TIMEOUT,
    MAX_CASES,
    Case,
    SweepSpec,
    SweepSpecError,
    load_spec,
    parse_spec,
    spec_from_dict,
)
from reference_impl.sweep._tasks import CaseTimeout, check_deadline, run_case

__all__ = [
    "DEFAULT_TIMEOUT",
    "MAX_CASES",
    "Case",
    "CaseFailed",
    "CaseTimeout",
    "Outcome",
    "SweepSpec",
    "SweepSpecError",
    "check_deadline",
    "dask_available",
    "dt_crit_map_on_cluster",
    "iter_outcomes",
    "load_spec",
    "open_client",
    "parse_spec",
    "run_case",
    "run_cases",
    "spec_from_dict",
]
