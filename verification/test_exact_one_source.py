"""One source per quadrature loop (issue 27, goal 7).

The exact solver's tanh-sinh and Gauss-Jacobi sums are written once, in
`reference_impl.exact._sums`, and bound to each integrand (the compiled node loops,
the power law's closed form, numpy node values) instead of being copied per path.
This test reads every module of `reference_impl.exact` (AST) and fails when another
one sums quadrature weights against values itself: an accumulation ``+=`` of a
product with a weight (``w``, ``w_diff``, ``W``, ``r.w``, ...), or a ``sum``/``dot``
over such a product. (Tool test, no claim mark.)
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from verification.assertions import assert_true

EXACT = Path(__file__).resolve().parent.parent / "reference_impl" / "exact"
HOME = "_sums.py"
# Names and attributes that hold a rule's weights in `exact`.
_WEIGHTS = {"w", "W", "w_diff", "w_coarse"}
# Modules whose weighted sums are not one of the two loops: the Gauss-Legendre pieces
# of the overdamped tail (a third rule, on x instead of s, with its own bisection).
_OTHER_RULES = {"_tail.py"}
# The general-law solver integrates the equation of motion (Taylor series, GBS), no
# quadrature rule; its W is a Taylor coefficient array (also in the lanes' series, which
# form the same recurrences for several impacts at once).
_NO_QUADRATURE = {
    "_general_kernel.py",
    "_general_taylor.py",
    "_taylor_lanes_series.py",
    "general_law.py",
    "_general_law_mp.py",
}


def _is_weight(node: ast.AST) -> bool:
    if isinstance(node, ast.Subscript):
        node = node.value
    if isinstance(node, ast.Name):
        return node.id in _WEIGHTS
    return isinstance(node, ast.Attribute) and node.attr in _WEIGHTS


def _weighted_product(node: ast.AST) -> bool:
    """A product one of whose factors (at any depth of the product) is a weight."""
    if isinstance(node, ast.BinOp) and isinstance(node.op, (ast.Mult, ast.MatMult)):
        return any(_is_weight(x) or _weighted_product(x) for x in (node.left, node.right))
    return False


def _weighted_sums(source: str) -> list[int]:
    """Lines that accumulate or sum a product of weights and values."""
    lines = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.AugAssign) and isinstance(node.op, ast.Add):
            if _weighted_product(node.value):
                lines.append(node.lineno)
        elif isinstance(node, ast.Call):
            f = node.func
            name = f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", "")
            if name in ("sum", "dot", "fsum") and any(_weighted_product(a) for a in node.args):
                lines.append(node.lineno)
        elif isinstance(node, ast.BinOp) and isinstance(node.op, ast.MatMult):
            if _is_weight(node.left) or _is_weight(node.right):
                lines.append(node.lineno)
    return sorted(set(lines))


def _modules():
    return sorted(
        p.name for p in EXACT.glob("*.py") if p.name not in _OTHER_RULES | _NO_QUADRATURE | {HOME}
    )


def test_the_home_module_holds_both_loops():
    tree = ast.parse((EXACT / HOME).read_text())
    found = sorted(
        f.name
        for f in tree.body
        if isinstance(f, ast.FunctionDef) and _weighted_sums(ast.unparse(f))
    )
    want = ["_gj_rows", "_row_compensated"]
    assert_true(
        all(w in found for w in want),
        got=f"weighted sums in {found}",
        should=f"{want} among them (the Gauss-Jacobi and tanh-sinh sums, seen by the checker)",
        claim="one source per loop",
        call=f"_weighted_sums({HOME})",
    )


@pytest.mark.parametrize("name", _modules())
def test_no_other_module_sums_quadrature_weights(name):
    lines = _weighted_sums((EXACT / name).read_text())
    assert_true(
        not lines,
        got=f"weighted sums at {name} lines {lines}",
        should=f"none: call the loops of exact/{HOME}",
        claim="one source per loop",
        call=f"_weighted_sums({name})",
    )


def test_pairwise_row_sum_is_numpys_sum_bit_for_bit():
    """The general path's tanh-sinh rows kept numpy's numbers when its np.sum became the
    compiled `_sums._pairwise`: the same order of additions, on every length (blocks of
    8 and 128, the halving above)."""
    import numpy as np

    from reference_impl.exact._sums import _pairwise

    rng = np.random.default_rng(27)
    bad = []
    for n in [*range(1, 300), 511, 1024, 1031, 4099]:
        a = rng.random(n) * 10.0 ** rng.uniform(-8, 8, n)
        if _pairwise(a, n) != np.sum(a):
            bad.append(n)
    assert_true(
        not bad,
        got=f"sums differ from np.sum at lengths {bad[:10]}",
        should="equal bit for bit at every length",
        claim="one source per loop",
        call="_sums._pairwise(a, n)",
    )
