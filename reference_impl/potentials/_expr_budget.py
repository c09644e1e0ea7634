"""Wall-time bounds on sympy's work for one user expression (`Expression`, issue 36 item 8).

sympy's limit, series and simplification of a formula can take exponential time in its
nesting (``sinh(sinh(sinh(q)))``: its leading exponent took more than 100 s; ``sin``
nested 60 deep ran past 600 s). Two bounds, one inside the other:

* `analysis_budget`: the whole analysis of one expression (parse, diff, lambdify, limits,
  series, the term table), at most ``seconds``; past it `ExpressionTimeout`, which
  `Expression` turns into one line naming the step and the formula;
* `time_limit`: one sympy series, at most ``seconds`` (`SeriesTimeout`; the caller falls
  back to raised-precision evaluation), nested inside the first.

Why SIGALRM and not a child process with a timeout: the alarm raises in the very thread
that does the work, between two Python bytecodes (sympy is pure Python; the big-integer
operations that would hold the interpreter are kept small by the parser's digit bound,
`_expr_parse._MAX_DIGITS`), so the work stops there and nothing is left running; a
child process would have to send back everything the analysis builds (lambdified
functions cannot be pickled) or run the analysis twice (every expression would cost two
analyses and a process start, ~1 s, and a fork of a process whose numba or Dask threads
hold a lock can hang). The alarm is only delivered to the main thread: elsewhere (a
worker thread) the analysis runs without the wall-time bound, held down by the parser's
static bounds alone (digits, nesting of transcendental functions, length and depth).
"""

from __future__ import annotations

import contextlib
import signal
import threading
import time

__all__ = ["ExpressionTimeout", "SeriesTimeout", "analysis_budget", "time_limit"]


class SeriesTimeout(BaseException):
    """sympy's series did not finish within its budget (or could not be bounded).

    A BaseException, like KeyboardInterrupt: sympy catches ``Exception`` broadly in
    places, and an alarm landing there would be swallowed and the series run on.
    """


class ExpressionTimeout(BaseException):
    """The analysis of one expression ran past its budget (a BaseException, as
    `SeriesTimeout`, so that neither sympy nor a series' fallback swallows it)."""


# Interval (s) at which an expired budget is signalled again until honoured.
_REARM_SECONDS = 0.1
# The deadlines in force (outermost first): [monotonic deadline (s), exception class,
# message]; the alarm is armed for the earliest, and an expiry raises the outermost
# expired one (an inner series' fallback must not swallow the whole analysis' expiry).
_STACK: list[tuple[float, type, str]] = []
_PREVIOUS = [None]


def _usable() -> bool:
    """SIGALRM can bound this block: the main thread, and no foreign alarm pending."""
    return (
        hasattr(signal, "setitimer")
        and threading.current_thread() is threading.main_thread()
        and (bool(_STACK) or signal.getitimer(signal.ITIMER_REAL)[0] == 0)
    )


def _arm() -> None:
    earliest = min(d for d, _, _ in _STACK)
    signal.setitimer(signal.ITIMER_REAL, max(earliest - time.monotonic(), 1e-4), _REARM_SECONDS)


def _expire(signum, frame):
    if _in_finalizer(frame):
        # An exception raised in a gc callback or a __del__ is not propagated: Python
        # prints it as "Exception ignored in ..." (a traceback warning in the test log)
        # and the work runs on. The timer re-fires in _REARM_SECONDS: raise then.
        return
    now = time.monotonic()
    for deadline, cls, message in _STACK:
        if now >= deadline:
            raise cls(message)


@contextlib.contextmanager
def _deadline(seconds: float, cls: type, message: str):
    if not _STACK:
        _PREVIOUS[0] = signal.signal(signal.SIGALRM, _expire)
    entry = (time.monotonic() + seconds, cls, message)
    _STACK.append(entry)
    _arm()
    try:
        yield
    finally:
        _STACK.remove(entry)
        if _STACK:
            _arm()
        else:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, _PREVIOUS[0])


@contextlib.contextmanager
def time_limit(seconds: float):
    """Raise `SeriesTimeout` inside the block after ``seconds`` of wall time.

    sympy's series of a nested formula can take exponential time (exp(exp(q))
    to order 10 takes 5 s, to order 14 minutes). The bound uses SIGALRM, which
    only the main thread can receive; elsewhere, or when another alarm than these
    budgets is pending, the block is not entered (SeriesTimeout at once) and the
    caller falls back to raised-precision evaluation.
    """
    if not _usable():
        raise SeriesTimeout("no way to bound sympy's series here")
    with _deadline(seconds, SeriesTimeout, f"sympy's series took more than {seconds} s"):
        yield


@contextlib.contextmanager
def analysis_budget(seconds: float):
    """Raise `ExpressionTimeout` inside the block after ``seconds`` of wall time (the main
    thread, no foreign alarm pending); elsewhere the block runs unbounded in time."""
    if not _usable():
        yield
        return
    with _deadline(seconds, ExpressionTimeout, f"more than {seconds:g} s"):
        yield


def _in_finalizer(frame) -> bool:
    """The signal arrived inside a gc callback, a ``__del__`` or a weakref finalizer."""
    import gc

    callbacks = {getattr(cb, "__code__", None) for cb in gc.callbacks}
    f = frame
    while f is not None:
        code = f.f_code
        if (
            code in callbacks
            or code.co_name in ("__del__", "_remove_dead_weakref")
            or (code.co_name == "__call__" and code.co_filename.endswith("weakref.py"))
        ):
            return True
        f = f.f_back
    return False
