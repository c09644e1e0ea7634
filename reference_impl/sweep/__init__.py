"""Parameter sweeps on Dask: ``hcv sweep`` and the `run_cases` engine other modules reuse.

A sweep spec (TOML: ``task``, a ``[scene]``, a ``[sweep]`` table of dotted paths
to lists) expands into the Cartesian product of cases (`load_spec`); each case
is a pure task keyed by a hash of its parameters, run on a local cluster of
processes or an existing Dask scheduler (`run_sweep`, `run_cases`). Dask is the
``sweep`` extra; `run_cases` falls back to serial in-process runs without it.
"""

from reference_impl.sweep._map import dt_crit_map_on_cluster
from reference_impl.sweep._runner import CaseFailed, Outcome, dask_available, iter_outcomes, open_client, run_cases
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
from reference_impl.cli.sweep import add_parser, run, run_sweep

__all__ = [
    "DEFAULT_TIMEOUT",
    "MAX_CASES",
    "Case",
    "CaseFailed",
    "CaseTimeout",
    "Outcome",
    "SweepSpec",
    "SweepSpecError",
    "add_parser",
    "check_deadline",
    "dask_available",
    "dt_crit_map_on_cluster",
    "iter_outcomes",
    "load_spec",
    "open_client",
    "parse_spec",
    "run",
    "run_case",
    "run_cases",
    "run_sweep",
    "spec_from_dict",
]
