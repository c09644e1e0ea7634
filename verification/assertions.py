"""Assertion helpers whose failures read "got X, should be Y [claim, call]"."""

from __future__ import annotations

import numpy as np

__all__ = ["assert_close", "assert_less", "assert_true", "check_measurement", "rel_err"]


def rel_err(got, expected) -> float:
    """Largest relative error max |got - expected| / max(|expected|, tiny)."""
    g = np.asarray(got, dtype=float)
    e = np.asarray(expected, dtype=float)
    scale = np.maximum(np.abs(e), np.finfo(float).tiny)
    return float(np.max(np.abs(g - e) / scale))


def _fmt(v) -> str:
    a = np.asarray(v, dtype=float)
    if a.size == 1:
        return f"{float(a):.17g}"
    return np.array2string(a, precision=17, threshold=8)


def assert_close(got, expected, *, rtol: float, atol: float = 0.0, claim: str, call: str) -> None:
    """Assert |got - expected| <= atol + rtol |expected| elementwise.

    The message names the worst element, the claim id and the call that produced ``got``.
    """
    g = np.asarray(got, dtype=float)
    e = np.asarray(expected, dtype=float)
    ok = np.abs(g - e) <= atol + rtol * np.abs(e)
    if not np.all(ok & np.isfinite(g)):
        bad = np.unravel_index(np.argmax(~(ok & np.isfinite(g))), np.broadcast(g, e).shape)
        gb = np.broadcast_to(g, np.broadcast(g, e).shape)[bad]
        eb = np.broadcast_to(e, np.broadcast(g, e).shape)[bad]
        raise AssertionError(
            f"got {gb:.17g}, should be {eb:.17g} (rel err {rel_err(gb, eb):.3g} > rtol {rtol:.3g}, "
            f"atol {atol:.3g}) [{claim}, {call}]"
        )


def assert_less(got, bound, *, claim: str, call: str, what: str = "value") -> None:
    """Assert got < bound (elementwise) with a claim-tagged message."""
    g = np.asarray(got, dtype=float)
    if not np.all(g < bound):
        raise AssertionError(
            f"got {what} = {_fmt(g.max())}, should be < {bound:.6g} [{claim}, {call}]"
        )


def assert_true(cond: bool, *, got: str, should: str, claim: str, call: str) -> None:
    """Assert a condition with a message in the house format."""
    if not cond:
        raise AssertionError(f"got {got}, should be {should} [{claim}, {call}]")


def check_measurement(m, *, expect: str, real=None, call: str, reason: str | None = None) -> None:
    """Assert a claim's measurement (`reference_impl.claims`) gives the recorded verdict.

    ``expect="verified"``: the measurement must verify the claim (a refutation
    fails the test, printing the evidence). ``expect="refuted"``: a strict
    expected failure -- the measurement must refute the claim, with a
    counterexample that ``real(m)`` (the test's own re-derivation) confirms; the
    test then xfails with the measured evidence as its reason (never a typed
    number). A refuted claim that measures as verified fails: update the record.
    ``reason`` (also produced from measured numbers) replaces the evidence as
    the xfail reason, e.g. to describe one case of a parametrized test.
    """
    import pytest

    if m.verdict == expect == "verified":
        return
    if m.verdict == "refuted" and expect == "refuted":
        ok = bool(m.counterexample) and (real is None or bool(real(m)))
        assert_true(
            ok,
            got=f"counterexample {m.counterexample!r} not confirmed by the test",
            should="a real counterexample",
            claim=m.claim,
            call=call,
        )
        pytest.xfail(f"{m.claim} refuted as printed: {reason or m.evidence}")
    raise AssertionError(
        f"got {m.verdict}: {m.evidence}, should be {expect} (rule: {m.rule}) [{m.claim}, {call}]"
    )
