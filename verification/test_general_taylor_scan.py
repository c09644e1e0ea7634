"""The zero-force scan of the Taylor kernel skips only steps where it could find nothing.

`_general_taylor.solve_taylor` skips the zero-force scan of a step on which an interval
bound proves the force positive (`_taylor_scan.force_stays_positive`; issue 38, goal 5).
The compiled kernel is compared, bit for bit, with the same algorithm that never skips
(its Python source re-bound with the bound answering False and compiled alike, ~3 s
once), over every law of the table on Hertz at speeds of three decades and with an
``rtol``; the skip must be taken on such runs (else the comparison proves nothing), and
a bound that always answers True must change the results (the comparison sees a wrong
bound; run as Python, both sides, where a compile would cost seconds more).
"""

from __future__ import annotations

import functools
import types

import numba
import numpy as np
import pytest

from reference_impl.exact import _general_taylor as gt
from reference_impl.exact import _law_batch, _taylor_scan, _taylor_step
from reference_impl.exact.general_law import prepare_law
from reference_impl.studies.laws import calibrated_laws, hertz
from verification.assertions import assert_true

CALL = "_general_taylor.solve_taylor"
CLAIM = "solve_law_impact (Taylor kernel)"
# Speeds (m/s) over three decades around the laws' calibration speed (1 m/s).
SPEEDS = (0.03, 0.1, 0.4, 1.0, 3.0, 10.0, 30.0)


def _rebind(fn, module, **names):
    """``fn``'s Python source with the globals ``names`` of its ``module`` replaced."""
    f = fn.py_func
    ns = dict(vars(module))
    ns.update(names)
    return types.FunctionType(f.__code__, ns, f.__name__, f.__defaults__, f.__closure__)


def _rebound(bound, jit=None):
    """`solve_taylor` whose step (`_taylor_step.after`, called by `integrate`) has its
    `_force_stays_positive` replaced by ``bound`` (run as Python, the compiled helpers they
    call stay compiled; ``jit``: all three compiled by it)."""
    wrap = jit or (lambda f: f)
    step = wrap(_rebind(_taylor_step.after, _taylor_step, _force_stays_positive=bound))
    stepping = wrap(_rebind(gt.integrate, gt, _after=step))
    return wrap(_rebind(gt.solve_taylor, gt, integrate=stepping))


@numba.njit(error_model="numpy")
def _never(F, C, j0, D, R, W, x):  # pragma: no cover - compiled
    return False


@functools.cache
def _never_skips():
    """The kernel that never skips the scan, compiled as `solve_taylor` is (the same float
    operations: a Python run differs in a few bits, e.g. its pow for rho**N)."""
    return _rebound(_never, numba.njit(error_model="numpy"))


def _rows(solver, law, rtol):
    """The kernel's rows (as int64 bits) and return codes of `SPEEDS` for ``law`` on Hertz."""
    pot, m = hertz()
    prepared = prepare_law(pot, m, law, rtol=rtol)
    plan = prepared._plan
    v = np.array(SPEEDS)
    tops = _law_batch._tops(plan, prepared, v)
    rows, codes = [], []
    for v0, qe in zip(v, tops, strict=True):
        out = np.full(len(gt.OUT_FIELDS), np.nan)
        codes.append(solver(v0, qe, plan.pk[0], plan.pk[1], plan.cs, plan.es, plan.sc, out))
        rows.append(out.view(np.int64).copy())
    return np.array(rows), codes


_CASES = [(name, rtol) for name in calibrated_laws() for rtol in (None, 1e-8)]


@pytest.mark.parametrize(("name", "rtol"), _CASES, ids=[f"{n}-{r}" for n, r in _CASES])
def test_skipped_scans_leave_every_bit(name, rtol):
    law = calibrated_laws()[name]
    want, want_codes = _rows(_never_skips(), law, rtol)
    got, codes = _rows(gt.solve_taylor, law, rtol)
    assert_true(
        codes == want_codes and np.array_equal(got, want),
        got=f"codes {codes}, rows differ at speeds "
        f"{[s for s, a, b in zip(SPEEDS, got, want, strict=True) if not np.array_equal(a, b)]}",
        should=f"the rows of the kernel that never skips a scan, bit for bit (codes {want_codes})",
        claim=CLAIM,
        call=f"{CALL}(law={law}, rtol={rtol}) at v0 = {SPEEDS}",
    )


@pytest.mark.parametrize("rtol", [None, 1e-8])
def test_the_skip_is_taken(rtol):
    # Counted on the Python twin: the comparison above proves nothing unless scans are
    # skipped on its runs (the linear dashpot pulls at the end, so its scans are searched).
    law = calibrated_laws()["linear"]
    taken = []

    def counted(*args):
        skip = _taylor_scan.force_stays_positive(*args)
        taken.append(skip)
        return skip

    _rows(_rebound(counted), law, rtol)
    assert_true(
        sum(taken) >= len(SPEEDS),
        got=f"{sum(taken)} of {len(taken)} zero-force scans skipped",
        should=f"at least one an impact ({len(SPEEDS)} impacts)",
        claim=CLAIM,
        call=f"{CALL}(law={law}, rtol={rtol})",
    )


def test_a_wrong_bound_is_seen():
    law = calibrated_laws()["linear"]
    want, _ = _rows(_rebound(lambda *args: False), law, None)
    wrong, _ = _rows(_rebound(lambda *args: True), law, None)
    assert_true(
        not np.array_equal(wrong, want),
        got="the same rows with every zero-force scan skipped",
        should="different rows (the zero-force end of the linear dashpot is then missed)",
        claim=CLAIM,
        call=f"{CALL}(law={law}) with _force_stays_positive always True",
    )


def test_bound_refuses_a_step_where_the_force_crosses_zero():
    # One step's series: rho = 1 - y, W = -1 (leaving at unit speed), G = rho^3 - c0 (j0 = 0):
    # c0 = 2, negative on the whole step; c0 = 0.5, through 0 at rho = 0.79 (y = 0.21, inside
    # [0, 0.5]); on [0, 0.01] (rho >= 0.99) it stays above 0.47: provably positive.
    R = np.zeros(gt.K + 1)
    W = np.zeros(gt.K + 1)
    R[0], R[1], W[0] = 1.0, -1.0, -1.0
    F = np.zeros(4)
    F[3] = 1.0
    for c0, x, want in ((2.0, 0.5, False), (0.5, 0.5, False), (0.5, 0.01, True)):
        C = np.zeros(4)
        C[0] = c0
        got = _taylor_scan.force_stays_positive(F, C, 0, 3, R, W, x)
        assert_true(
            got == want,
            got=f"{got}",
            should=f"{want} (G = rho^3 - {c0} on rho in [{1 - x}, 1])",
            claim=CLAIM,
            call=f"force_stays_positive(F = rho^3, C = {c0}, x = {x})",
        )
