"""User-written potentials: hostile or malformed text is refused safely, and nothing runs.

The formula is never executed: a whitelist walk over its syntax tree builds a
sympy expression. These tests check that hostile or malformed text is refused
quickly with a one-line `ExpressionError` and nothing runs (a sentinel file is not
created, and eval/exec are tripwired), that no module on the path from text to
sympy calls eval, that bad parameters are named, and that params/repr round-trip.
Evaluation, exponents and the assumptions of section 3: `test_expression.py`.
"""

from __future__ import annotations

import ast
import builtins
import subprocess
import sys
import time
import types
from pathlib import Path

import pytest

import reference_impl.potentials.expression as expression_module
from reference_impl.errors import ExpressionError
from reference_impl.potentials import Expression
from verification.assertions import assert_close, assert_less, assert_true

# Wall-clock budget (s) for refusing a hostile string: all refusals are
# syntax-tree checks that take microseconds; 1 s only flags a hang.
_REFUSE_SECONDS = 1.0
# Budget (s) for a fresh interpreter to import sympy and refuse four power
# towers; evaluating any of them would take hours.
_SUBPROCESS_SECONDS = 60.0


# -- hostile and malformed text ---------------------------------------------------


_real_compile, _real_exec, _real_eval = builtins.compile, builtins.exec, builtins.eval


def _from_module_file(code) -> bool:
    """True for a code object of a real source file (a lazy import inside sympy)."""
    return isinstance(code, types.CodeType) and Path(code.co_filename).is_file()


def _exec_guard(code, *args, **kwargs):
    if not _from_module_file(code):
        raise AssertionError(f"exec of {str(code)[:60]!r} while refusing a formula")
    return _real_exec(code, *args, **kwargs)


def _eval_guard(code, *args, **kwargs):
    if not _from_module_file(code):
        raise AssertionError(f"eval of {str(code)[:60]!r} while refusing a formula")
    return _real_eval(code, *args, **kwargs)


def _compile_ast_only(source, filename, mode, flags=0, *args, **kwargs):
    """compile() that only builds syntax trees (what ast.parse needs), never code."""
    if not flags & ast.PyCF_ONLY_AST:
        raise AssertionError("compile() to code was called while refusing a formula")
    return _real_compile(source, filename, mode, flags, *args, **kwargs)


def _hostile(sentinel: Path) -> list[tuple[str, str]]:
    """(formula, text the message must contain): refused before sympy prints any code."""
    s = str(sentinel)
    return [
        (f"__import__('os').system('touch {s}')", "'__import__'"),
        (f"open('{s}', 'w').write('x')", "call of"),
        (f"open('{s}', 'w')", "call of 'open'"),
        ("().__class__.__bases__", "'__bases__'"),
        ("q.__class__", "'__class__'"),
        ("lambda: 1", "lambda"),
        ("q if 1 else 2", "conditional expression"),
        ("9**9**9**9", "|exponent| must be <= 1074"),
        ("9**9**9", "|exponent| must be <= 1074"),
        ("(10**300)**300*q", "overflows float64"),
        ("q.real", "attribute access"),
        ("q[0]", "subscript"),
        ("os", "name 'os' is not allowed (allowed: q, sqrt"),
        ("getattr(q, 'x')", "'getattr'"),
        ("sqrt(x=q)", "keyword"),
        ("f'{q}'", "f-string"),
        ("(y := q)", "assignment expression"),
        ("'q'", "str constant"),
        ("q + 1j", "complex constant"),
        ("[q for q in ()]", "comprehension"),
        ("q < 1", "comparison"),
        ("q ^ 2", "write ** for a power"),
        ("q" * 10_000, "more than the limit 2000"),
        ("", "empty"),
        ("q +", "syntax error"),
        ("-" * 500 + "q", "nested more than"),
        ("\x00q", "syntax error"),
        ("sqrt(-1)*q", "non-real"),
        ("q/0", "division by zero"),
        ("q - q", "does not depend on q"),
        ("2.0", "does not depend on q"),
    ]


def _refuse(source: str, needle: str) -> None:
    """Expression(source) must raise a one-line ExpressionError containing ``needle``, fast."""
    start = time.perf_counter()
    with pytest.raises(ExpressionError) as info:
        Expression(source)
    elapsed = time.perf_counter() - start
    call = f"Expression({source[:40]!r})"
    assert_less(elapsed, _REFUSE_SECONDS, claim="expression", call=call, what="seconds")
    msg = str(info.value)
    assert_true(
        needle in msg and "\n" not in msg and len(msg) < 400,
        got=repr(msg),
        should=f"one short line containing {needle!r}",
        claim="expression",
        call=call,
    )


def test_hostile_strings_are_refused_and_nothing_runs(tmp_path, monkeypatch):
    sentinel = tmp_path / "pwned"
    for source, needle in _hostile(sentinel):
        with monkeypatch.context() as mp:
            mp.setattr(builtins, "eval", _eval_guard)
            mp.setattr(builtins, "exec", _exec_guard)
            mp.setattr(builtins, "compile", _compile_ast_only)
            _refuse(source, needle)
    assert_true(
        not sentinel.exists(),
        got="sentinel file created",
        should="nothing executed",
        claim="expression",
        call="hostile strings",
    )


def test_power_towers_fail_fast_in_a_fresh_process():
    """9**9**9**9 refused without evaluating it; a hang (big-int power holds the GIL,
    so no thread can time it out) is caught by the subprocess timeout."""
    code = (
        "from reference_impl.potentials import Expression\n"
        "for s in ('9**9**9**9', '9**9**9', '2**2**2**2**2**2*q', '(10**300)**300**2*q'):\n"
        "    try:\n        Expression(s)\n    except Exception as e:\n"
        "        print(type(e).__name__)\n"
    )
    try:
        out = subprocess.run(
            [sys.executable, "-c", code],
            capture_output=True,
            text=True,
            timeout=_SUBPROCESS_SECONDS,
        )
    except subprocess.TimeoutExpired:
        out = None
    got = "timeout" if out is None else (out.stdout + out.stderr).split()
    assert_true(
        got == ["ExpressionError"] * 4,
        got=str(got),
        should="4 x ExpressionError",
        claim="expression",
        call="power towers",
    )


@pytest.mark.parametrize(
    "source,needle",
    [
        ("sqrt(-q)", "is not real"),
        ("(-8)**(1/3)*q", "non-real"),
        ("exp(1000)*q", "overflows float64"),
        ("1e999*q", "overflows float64"),
        ("q**2 + sqrt", "call it, e.g. sqrt(q)"),
        ("sqrt(q, 2)", "sqrt takes 1 argument, got 2"),
        ("q // 2", "floor division"),
        ("min(q, 1)", "call of 'min'"),
    ],
)
def test_malformed_formulas_are_refused(source, needle):
    _refuse(source, needle)


def test_module_never_calls_eval():
    """No eval/exec/compile/sympify/parse_expr call anywhere in the modules' source
    (the potential, its parser `_expr_parse`, its turning-point search `_expr_turning`,
    and `_terms`, which reads its sympy form into the term table)."""
    from reference_impl.potentials import _expr_parse, _expr_turning, _terms

    banned = {"eval", "exec", "compile", "sympify", "parse_expr", "S"}
    calls = []
    for module in (expression_module, _expr_parse, _expr_turning, _terms):
        tree = ast.parse(Path(module.__file__).read_text())
        calls += [
            getattr(n.func, "id", getattr(n.func, "attr", ""))
            for n in ast.walk(tree)
            if isinstance(n, ast.Call)
        ]
    hits = sorted(set(calls) & banned)
    assert_true(
        not hits,
        got=f"calls {hits}",
        should="none",
        claim="expression",
        call="expression.py, _expr_parse.py, _expr_turning.py and _terms.py source",
    )


@pytest.mark.parametrize(
    "params,needle",
    [
        (dict(k=float("nan")), "k = nan must be a finite real number"),
        (dict(k=float("inf")), "k = inf must be a finite real number"),
        (dict(k=True), "k = True"),
        (dict(k="1"), "k = '1'"),
        (dict(k=1.0, q=2.0), "'q' collides"),
        (dict(k=1.0, sqrt=2.0), "'sqrt' collides"),
        (dict(k=1.0, pi=2.0), "'pi' collides"),
        (dict(k=1.0, _x=2.0), "'_x' is not allowed"),
        (dict(k=1.0, kk=2.0), "parameter 'kk' is not used"),
        (dict(), "name 'k' is not allowed"),
    ],
)
def test_bad_parameters(params, needle):
    with pytest.raises(ExpressionError) as info:
        Expression("k*q**2", **params)
    assert_true(
        needle in str(info.value),
        got=str(info.value),
        should=f"contains {needle!r}",
        claim="expression",
        call=f"Expression('k*q**2', **{params})",
    )


def test_params_and_repr():
    expr = Expression("k*q**3/3 + q**2/2", k=2.0)
    assert_true(
        expr.params() == {"U": "k*q**3/3 + q**2/2", "params": {"k": 2.0}},
        got=repr(expr.params()),
        should="U and params",
        claim="expression",
        call="params",
    )
    assert_true(
        repr(expr) == "Expression('k*q**3/3 + q**2/2', k=2.0)",
        got=repr(expr),
        should="Expression('k*q**3/3 + q**2/2', k=2.0)",
        claim="expression",
        call="repr",
    )
    again = Expression(expr.params()["U"], **expr.params()["params"])
    assert_close(again.U(1.5), expr.U(1.5), rtol=0.0, claim="expression", call="round trip")
