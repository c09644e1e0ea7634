"""Root pytest configuration: hypothesis profiles and the claim marker.

Select a profile with HYPOTHESIS_PROFILE=ci|dev|thorough (default: dev; CI sets ci).

``pytest -m smoke`` is the first try on a new machine (issue 26: <= 2 min on 2 cores): for each
registered claim, the first collected test that checks it and is not marked slow, plus the
end-to-end command tests named in ``_SMOKE_EXTRA``. The selection is made here, at collection
time, so a new claim's first test joins it without an edit.
"""

from __future__ import annotations

import os
import signal
import threading

from hypothesis import HealthCheck, settings

# Ctrl-C as a terminal delivers it. A shell without job control starts a background job
# (`cmd &`, as a CI script or `nohup ... &` may) with SIGINT ignored (POSIX), Python then
# installs no handler, and every process the tests start inherits the ignore: the tests
# of Ctrl-C (a compiled lane, a gate's adapter, a cluster) wait for a signal that never
# arrives (seen: a `.ci/run` started with `&` failed two of them). A handled signal is
# reset to the default at exec, so the processes the tests start get it too.
if (
    threading.current_thread() is threading.main_thread()
    and signal.getsignal(signal.SIGINT) == signal.SIG_IGN
):
    signal.signal(signal.SIGINT, signal.default_int_handler)

settings.register_profile(
    "ci",
    derandomize=True,
    database=None,
    max_examples=25,
    deadline=None,
    print_blob=True,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.register_profile(
    "dev", max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)
settings.register_profile(
    "thorough", max_examples=500, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "dev"))


# Tests besides one per claim that a first try should run: the main commands end to end.
_SMOKE_EXTRA = (
    "verification/test_cli.py::test_solve_json_embedded_paper_scene",
    "verification/test_cli.py::test_dt_crit_json_reports_each_velocity",
    "verification/test_cli.py::test_bad_input_exit_2_one_line",
)


def pytest_configure(config):
    """Declare each built-in code's marker from the adapter registry (its `CodeInfo`:
    marker, code, install line), so that a new code needs no line in pyproject.toml's
    marker list (issue 37's change exercise)."""
    from reference_impl.adapters.registry import builtin_codes

    for info in builtin_codes().values():
        how = (
            f"pip install -e '.[{info.extra}]'" if info.extra else f"apt-get install -y {info.apt}"
        )
        config.addinivalue_line(
            "markers",
            f"{info.marker}: needs {info.code} ({how}); deselect with -m 'not {info.marker}'",
        )


def pytest_collection_modifyitems(config, items):
    """Reject a claim marker that names an unregistered claim; choose the smoke tests."""
    import pytest

    from verification.claims import claim_ids

    known = set(claim_ids())
    smoked: set[str] = set()
    for item in items:
        for mark in item.iter_markers("claim"):
            if not mark.args or mark.args[0] not in known:
                raise ValueError(
                    f"{item.nodeid}: claim marker {mark.args!r} names no registered claim "
                    f"(see verification/claims.py)"
                )
            claim = mark.args[0]
            if claim not in smoked and item.get_closest_marker("slow") is None:
                smoked.add(claim)
                item.add_marker(pytest.mark.smoke)
        if item.nodeid.split("[")[0] in _SMOKE_EXTRA:
            item.add_marker(pytest.mark.smoke)
    # A renamed test must not leave the smoke run silently smaller: every extra whose module
    # was collected must name a function of that module.
    modules = {item.nodeid.split("::")[0]: item.module for item in items if hasattr(item, "module")}
    lost = [
        t
        for t in _SMOKE_EXTRA
        if t.split("::")[0] in modules and not hasattr(modules[t.split("::")[0]], t.split("::")[1])
    ]
    if lost:
        raise ValueError(f"conftest._SMOKE_EXTRA names tests that do not exist: {lost}")
