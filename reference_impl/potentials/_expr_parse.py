"""Whitelist parser for user formulas U(q): Python syntax in, sympy expression out.

The text is parsed with `ast.parse` and never executed; the syntax tree is walked
through a whitelist (numbers, ``q``, declared parameters, a fixed set of
functions, ``pi``, ``E``, ``+ - * / **``) and the sympy expression is built node
by node. Limits on length, nesting depth and numeric exponents keep hostile input
from reaching sympy. Used by `reference_impl.potentials.expression.Expression`.
"""

from __future__ import annotations

import ast
import keyword
import math
from typing import Any

import numpy as np
import sympy as sp

from reference_impl.errors import ExpressionError
from reference_impl.potentials._checks import is_real_number

# Longest accepted source: a contact law is a line of algebra; the cap keeps
# parsing and sympy's work bounded on hostile or accidental input.
_MAX_SOURCE_CHARS = 2000
# Deepest accepted nesting of the syntax tree: a 100-term polynomial still fits,
# sympy needs about 1 s for it, and the recursive walk stays far from Python's limit.
_MAX_DEPTH = 100
# Largest |exponent| of a numeric power: float64 spans 2**+-1074, so any larger
# exponent is an overflow or a hang (9**9**9 has 370 million digits).
_MAX_EXPONENT = 1074
# Most decimal digits of the numerator or denominator of any number the formula forms (a
# literal, a power, a product of constants): the exact value of every float64 number
# written in its shortest decimal form has at most 326 (5e-324 = 5/10**324; the largest,
# ~1.8e308, 309 digits), so 400 admits every float64 constant. Larger numbers reached
# Python's int-to-str limit (4300 digits) inside sympy's printing (a traceback), and their
# arithmetic grows with every derivative (issue 36).
_MAX_DIGITS = 400
# Deepest nesting of transcendental calls (exp, log, sin, ... not sqrt or abs): sympy's
# limit and series at q -> 0 grow exponentially with it (measured on a shared 2-core
# machine: sin nested 5 deep 4.3 s, asinh 5 deep 7.7 s, sin 60 deep past 600 s). A contact
# law nests two or three (log(cosh(q)), q*tanh(sqrt(q))); the wall-time budget of the whole
# analysis (`_expr_budget`) catches the rest (sinh(sinh(sinh(q))) takes > 100 s).
_MAX_NESTING = 4
# Functions that count toward _MAX_NESTING (algebraic ones do not: sqrt(sqrt(q)) = q**(1/4)).
_ALGEBRAIC = ("sqrt", "abs")
# Characters of the source quoted in a message, so errors stay one short line.
_QUOTE_CHARS = 60
# Digits used to check that each constant of U fits in float64 (magnitude only).
_CONST_DPS = 15
# Only real=True: with positive=True sympy's assumption system makes diff of a
# 60-term polynomial take 13 s instead of 0.2 s. q > 0 enters where it matters,
# through limits taken from the right.
_Q = sp.Symbol("q", real=True)

# name -> sympy function of one positional argument. min and max are left out
# on purpose: sympy's limit at q -> 0+ of their piecewise form gives wrong
# leading exponents (min(q, q**2) -> 1 instead of 2).
_FUNCTIONS = {
    "sqrt": sp.sqrt,
    "exp": sp.exp,
    "log": sp.log,
    "sin": sp.sin,
    "cos": sp.cos,
    "tan": sp.tan,
    "sinh": sp.sinh,
    "cosh": sp.cosh,
    "tanh": sp.tanh,
    "atan": sp.atan,
    "asinh": sp.asinh,
    "abs": sp.Abs,
}
_CONSTANTS = {"pi": sp.pi, "E": sp.E}
_BINOPS = {
    ast.Add: lambda a, b: a + b,
    ast.Sub: lambda a, b: a - b,
    ast.Mult: lambda a, b: a * b,
    ast.Div: lambda a, b: a / b,
}
# Operators users plausibly type by mistake, with the fix to suggest.
_BINOP_HINTS = {
    ast.BitXor: "'^' is bitwise xor in Python; write ** for a power",
    ast.FloorDiv: "'//' is floor division; write /",
    ast.Mod: "'%' (modulo) is not a contact law operation",
    ast.MatMult: "'@' is matrix multiplication",
}
# Plain words for rejected syntax, so the message says what was found.
_NODE_NAMES = (
    (ast.Attribute, "attribute access"),
    (ast.Subscript, "subscript"),
    (ast.Lambda, "lambda"),
    (ast.IfExp, "conditional expression"),
    (ast.Compare, "comparison"),
    (ast.BoolOp, "boolean operator"),
    (ast.NamedExpr, "assignment expression"),
    ((ast.JoinedStr, ast.FormattedValue), "f-string"),
    ((ast.List, ast.Tuple, ast.Set, ast.Dict), "container literal"),
    ((ast.ListComp, ast.SetComp, ast.DictComp, ast.GeneratorExp), "comprehension"),
)
_FUNC_LIST = ", ".join(_FUNCTIONS)


def _short(text: str) -> str:
    """The text quoted for a message, cut to one short line."""
    one = " ".join(text.split())
    return repr(one if len(one) <= _QUOTE_CHARS else one[: _QUOTE_CHARS - 3] + "...")


def _as_float(v) -> float:
    """``v`` as a float: +-inf for oo or an int beyond float64, nan if it is not real."""
    try:
        return float(v)
    except OverflowError:
        return math.inf if v > 0 else -math.inf
    except (TypeError, ValueError):
        return math.nan


def _digits(n: int) -> int:
    """Decimal digits of |n| (within one), without converting it to a string (Python
    refuses str() beyond 4300 digits)."""
    return int(abs(n).bit_length() * 0.30103) + 1


def _too_long(expr: sp.Expr) -> int:
    """The digits of the longest numerator or denominator of ``expr``'s numeric
    coefficient (a number, or the constant factor or term sympy folded into a product or
    sum), when above _MAX_DIGITS; else 0."""
    if expr.is_Rational:
        coeff = expr
    elif expr.is_Mul:
        coeff = expr.as_coeff_Mul()[0]
    elif expr.is_Add:
        coeff = expr.as_coeff_Add()[0]
    else:
        return 0
    if not coeff.is_Rational:
        return 0
    most = max(_digits(coeff.p), _digits(coeff.q))
    return most if most > _MAX_DIGITS else 0


def check_digits(expr: sp.Expr, what: str, source: str, limit: int) -> None:
    """Refuse ``expr`` (``what`` of U = ``source``) when a number in it has more than
    ``limit`` digits in its numerator or denominator (one line, the digits named)."""
    for a in expr.atoms(sp.Rational):
        most = max(_digits(a.p), _digits(a.q))
        if most > limit:
            raise ExpressionError(
                f"Expression: {what} of U = {_short(source)} has a number of {most} digits, "
                f"more than {limit}; write its constants as decimal floats (e.g. 1.5e+30)"
            )


def _shown(value) -> str:
    """``value`` for a message: its repr cut to one short line; an integer too long for
    repr (Python's 4300-digit int-to-str limit) by its digit count."""
    if isinstance(value, int) and _digits(value) > _QUOTE_CHARS:
        return f"an integer of {_digits(value)} digits"
    return repr(value)[:_QUOTE_CHARS]


def _exact(value) -> sp.Rational:
    """Exact sympy value of an int, or of the shortest decimal that reads back as the float."""
    if isinstance(value, (int, np.integer)):
        return sp.Integer(int(value))
    return sp.Rational(repr(float(value)))


class _Builder:
    """Walk an `ast` tree through the whitelist and build the sympy expression."""

    def __init__(self, source: str, values: dict[str, sp.Expr]):
        self.source = source
        self.values = values  # parameter name -> exact value
        self.nesting = 0  # transcendental calls around the node being built

    def fail(self, node: ast.AST, what: str, hint: str) -> ExpressionError:
        token = ast.get_source_segment(self.source, node) or type(node).__name__
        col = getattr(node, "col_offset", None)
        where = f" at column {col + 1}" if col is not None else ""
        return ExpressionError(f"Expression: {what} {_short(token)}{where} is not allowed ({hint})")

    def build(self, node: ast.AST, depth: int = 0) -> sp.Expr:
        out = self._build(node, depth)
        most = _too_long(out)
        if most:
            raise self.fail(
                node,
                "number",
                f"its exact value has {most} digits, more than {_MAX_DIGITS}: write it as "
                "a decimal float, e.g. 1.5e+30",
            )
        return out

    def _build(self, node: ast.AST, depth: int) -> sp.Expr:
        if depth > _MAX_DEPTH:
            raise ExpressionError(
                f"Expression: the formula is nested more than {_MAX_DEPTH} levels deep; "
                "simplify it or split it into a sum of potentials"
            )
        d = depth + 1
        if isinstance(node, ast.Expression):
            return self.build(node.body, d)
        if isinstance(node, ast.Constant):
            return self._constant(node)
        if isinstance(node, ast.Name):
            return self._name(node)
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            inner = self.build(node.operand, d)
            return -inner if isinstance(node.op, ast.USub) else inner
        if isinstance(node, ast.UnaryOp):
            raise self.fail(node, "unary operator in", "only unary + and - are allowed")
        if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Pow):
            return self._power(node, d)
        if isinstance(node, ast.BinOp):
            op = _BINOPS.get(type(node.op))
            if op is None:
                hint = _BINOP_HINTS.get(type(node.op), "allowed operators: + - * / **")
                raise self.fail(node, "operator in", hint)
            return op(self.build(node.left, d), self.build(node.right, d))
        if isinstance(node, ast.Call):
            return self._call(node, d)
        what = next((t for c, t in _NODE_NAMES if isinstance(node, c)), type(node).__name__)
        hint = f"allowed: numbers, names, + - * / ** and calls of {_FUNC_LIST}"
        raise self.fail(node, what, hint)

    def _constant(self, node: ast.Constant) -> sp.Expr:
        v = node.value
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise self.fail(node, f"{type(v).__name__} constant", "only real numbers are allowed")
        if not math.isfinite(_as_float(v)):
            raise self.fail(node, "number", "it overflows float64")
        return _exact(v)

    def _name(self, node: ast.Name) -> sp.Expr:
        name = node.id
        if name == "q":
            return _Q
        if name in self.values:
            return self.values[name]
        if name in _CONSTANTS:
            return _CONSTANTS[name]
        if name in _FUNCTIONS:
            raise self.fail(node, "bare function name", f"call it, e.g. {name}(q)")
        allowed = ", ".join(["q", *self.values, *_FUNCTIONS, *_CONSTANTS])
        raise ExpressionError(
            f"Expression: name {name!r} is not allowed (allowed: {allowed}); give a value for it "
            "if it is a parameter"
        )

    def _power(self, node: ast.BinOp, d: int) -> sp.Expr:
        base, expo = self.build(node.left, d), self.build(node.right, d)
        if expo.is_number:
            mag = _as_float(abs(expo if expo.is_Rational else sp.N(expo, _CONST_DPS)))
            if not mag <= _MAX_EXPONENT:
                raise self.fail(node, "power", f"|exponent| must be <= {_MAX_EXPONENT}")
        out = base**expo
        if out.is_Rational and not math.isfinite(_as_float(abs(out))):
            raise self.fail(node, "power", "its value overflows float64")
        return out

    def _call(self, node: ast.Call, d: int) -> sp.Expr:
        if not isinstance(node.func, ast.Name) or node.func.id not in _FUNCTIONS:
            raise self.fail(node.func, "call of", f"only {_FUNC_LIST} may be called")
        name = node.func.id
        if node.keywords or any(isinstance(a, ast.Starred) for a in node.args):
            raise self.fail(node, "keyword or starred argument in", f"call {name}(q) plainly")
        if len(node.args) != 1:
            raise self.fail(node, "call", f"{name} takes 1 argument, got {len(node.args)}")
        if name in _ALGEBRAIC:
            return _FUNCTIONS[name](self.build(node.args[0], d))
        if self.nesting >= _MAX_NESTING:
            raise self.fail(
                node,
                "call",
                f"transcendental functions nest more than {_MAX_NESTING} deep here; sympy's "
                "analysis grows exponentially with the nesting",
            )
        self.nesting += 1
        try:
            return _FUNCTIONS[name](self.build(node.args[0], d))
        finally:
            self.nesting -= 1


def _check_inputs(source, params: dict[str, Any]) -> None:
    """Reject a source that is not a short non-empty string, and unusable parameters."""
    if not isinstance(source, str):
        raise ExpressionError(f"Expression: the formula must be a string, got {source!r}")
    if not source.strip():
        raise ExpressionError("Expression: the formula is empty; write U(q), e.g. 'k*q**2/2'")
    if len(source) > _MAX_SOURCE_CHARS:
        raise ExpressionError(
            f"Expression: the formula has {len(source)} characters, more than the limit "
            f"{_MAX_SOURCE_CHARS}; simplify it or split it into a sum of potentials"
        )
    for name, value in params.items():
        if not name.isidentifier() or keyword.iskeyword(name) or name.startswith("_"):
            raise ExpressionError(
                f"Expression: parameter name {name!r} is not allowed; use letters, digits and "
                "'_' not at the start"
            )
        if name == "q" or name in _FUNCTIONS or name in _CONSTANTS:
            raise ExpressionError(
                f"Expression: parameter name {name!r} collides with the variable q or a built-in "
                "function or constant; rename the parameter"
            )
        if not is_real_number(value) or not math.isfinite(_as_float(value)):
            raise ExpressionError(
                f"Expression: parameter {name} = {_shown(value)} must be a finite real number"
            )


def _parse(source: str, params: dict[str, float]) -> sp.Expr:
    """The sympy expression of ``source``, built through the whitelist (never executed)."""
    text = source.strip()
    try:
        tree = ast.parse(text, mode="eval")
    except SyntaxError as e:
        col = f" at column {e.offset}" if e.offset else ""
        msg = f"Expression: syntax error{col}: {e.msg} in {_short(text)}"
        raise ExpressionError(msg) from None
    except ValueError as e:
        # Python refuses an integer literal of more than 4300 digits (int_max_str_digits).
        what = "an integer literal is too long" if "digits" in str(e) else "cannot parse"
        msg = f"Expression: {what} in {_short(text)}; check the formula"
        raise ExpressionError(msg) from None
    except (RecursionError, MemoryError):
        msg = f"Expression: cannot parse {_short(text)}; check the formula"
        raise ExpressionError(msg) from None
    # Every identifier first: a dunder anywhere (the usual sandbox escape) is
    # reported as such, before any other complaint.
    for node in ast.walk(tree):
        for ident in (getattr(node, "id", None), getattr(node, "attr", None)):
            if isinstance(ident, str) and ident.startswith("_"):
                raise ExpressionError(
                    f"Expression: name {ident!r} is not allowed (names starting with '_' never "
                    f"are); write U(q) with q, parameters, numbers and {_FUNC_LIST}"
                )
    try:
        expr = _Builder(text, {k: _exact(v) for k, v in params.items()}).build(tree)
    except RecursionError:
        raise ExpressionError(f"Expression: {_short(text)} is nested too deeply") from None
    used = {n.id for n in ast.walk(tree) if isinstance(n, ast.Name)}
    unused = [k for k in params if k not in used]
    if unused:
        raise ExpressionError(
            f"Expression: parameter {unused[0]!r} is not used in U = {_short(text)}; remove it "
            "or fix its spelling"
        )
    return expr


def _check_expr(expr: sp.Expr, source: str) -> None:
    """Reject a formula that sympy reduced to something unusable as U(q)."""
    src = _short(source)
    if expr.has(sp.zoo, sp.nan, sp.oo, -sp.oo):
        raise ExpressionError(
            f"Expression: U = {src} contains a division by zero or an infinite constant (sympy "
            f"reads it as {_short(str(expr))})"
        )
    if _Q not in expr.free_symbols:
        raise ExpressionError(
            f"Expression: U = {src} does not depend on q (it reduces to {_short(str(expr))}); "
            "write the potential as a function of the overlap q"
        )
    for sub in sp.preorder_traversal(expr):
        if (sub is expr or sub.is_number) and sub.is_extended_real is False:
            raise ExpressionError(
                f"Expression: U = {src} has the non-real part {_short(str(sub))}; U must be real "
                "for q >= 0"
            )
        if sub.is_number and not math.isfinite(_as_float(abs(sp.N(sub, _CONST_DPS)))):
            raise ExpressionError(
                f"Expression: the constant {_short(str(sub))} in U = {src} overflows float64; "
                "rescale the formula"
            )
