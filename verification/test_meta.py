"""Meta-tests: every claim has a home and a test, every mark names a claim.

The marks are read from the test sources by the one scanner
(`reference_impl.claims._scan`, also used by the report), so the check does
not depend on which tests a run selected.
"""

from __future__ import annotations

import ast
import inspect
import textwrap
from pathlib import Path

from reference_impl.claims import _scan, _tolerances
from reference_impl.claims._base import Measurement
from verification.assertions import assert_true
from verification.claims import CLAIMS, claim_ids

HERE = Path(__file__).parent
# Names of a claim module every claim must define.
REQUIRED = ("ID", "SECTION", "STATEMENT", "measure")


def test_every_claim_has_a_test():
    tests = _scan.claim_tests(HERE)
    missing = [c.id for c in CLAIMS if not tests.get(c.id)]
    assert_true(
        not missing,
        got=f"claims without tests {missing}",
        should="none",
        claim="meta",
        call="claim_tests()",
    )


def test_every_mark_names_a_claim():
    known = set(claim_ids())
    unknown = [
        f"{m.file}:{m.line} {m.claim!r}"
        for m in _scan.scan_claim_marks(HERE)
        if m.claim not in known
    ]
    assert_true(
        not unknown,
        got=f"marks naming no registered claim {unknown}",
        should="none",
        claim="meta",
        call="scan_claim_marks()",
    )


def test_claim_ids_unique():
    ids = claim_ids()
    assert_true(
        len(ids) == len(set(ids)),
        got=f"{len(ids)} ids, {len(set(ids))} distinct",
        should="all distinct",
        claim="meta",
        call="claim_ids()",
    )


def test_every_claim_module_defines_its_home():
    for c in CLAIMS:
        mod = c.home
        missing = [n for n in REQUIRED if not hasattr(mod, n)]
        assert_true(
            not missing and mod.ID == c.id,
            got=f"{mod.__name__}: missing {missing}, ID {getattr(mod, 'ID', None)!r}",
            should=f"{REQUIRED} with ID {c.id!r}",
            claim="meta",
            call=mod.__name__,
        )
        sig = inspect.signature(mod.measure)
        assert_true(
            list(sig.parameters) == ["quick"] and sig.parameters["quick"].default is False,
            got=f"measure{sig}",
            should="measure(quick: bool = False)",
            claim="meta",
            call=f"{mod.__name__}.measure",
        )
        assert_true(
            hasattr(mod.measure, "cache_info"),
            got="measure is not cached",
            should="functools.cache'd (measured once per process)",
            claim="meta",
            call=f"{mod.__name__}.measure",
        )


def _numeric(node) -> bool:
    """A literal number, a tuple of them, or arithmetic / mpf() of literals."""
    if isinstance(node, ast.Constant):
        return isinstance(node.value, (int, float)) and not isinstance(node.value, bool)
    if isinstance(node, ast.Tuple):
        return bool(node.elts) and all(_numeric(e) for e in node.elts)
    if isinstance(node, (ast.UnaryOp, ast.BinOp)):
        return all(_numeric(n) for n in ast.iter_child_nodes(node) if isinstance(n, ast.expr))
    if isinstance(node, ast.Call):
        return bool(node.args) and all(
            _numeric(a) or (isinstance(a, ast.Constant) and isinstance(a.value, str))
            for a in node.args
        )
    return False


def _uncommented_constants(path: Path) -> list[str]:
    """Module-level numeric UPPER_CASE constants with no comment on or just above their line."""
    src = path.read_text().splitlines()
    bad = []
    for node in ast.parse("\n".join(src)).body:
        if not isinstance(node, ast.Assign) or not _numeric(node.value):
            continue
        names = [t.id for t in node.targets if isinstance(t, ast.Name)]
        names += [
            e.id
            for t in node.targets
            if isinstance(t, ast.Tuple)
            for e in t.elts
            if isinstance(e, ast.Name)
        ]
        if not names or not all(n.isupper() or n.strip("_").isupper() for n in names):
            continue
        line = src[node.lineno - 1]
        above = src[node.lineno - 2].strip() if node.lineno >= 2 else ""
        if "#" not in line and not above.startswith("#"):
            bad.append(f"{path.name}:{node.lineno} {', '.join(names)}")
    return bad


def test_every_tolerance_states_its_reason():
    """Each numeric constant of a claim module (a tolerance, a precision, a case
    setting) carries a comment giving the reason for its size."""
    paths = [Path(c.home.__file__) for c in CLAIMS] + [Path(_tolerances.__file__)]
    bad = [b for p in paths for b in _uncommented_constants(p)]
    assert_true(
        not bad,
        got=f"constants without a reason {bad}",
        should="none",
        claim="meta",
        call="_uncommented_constants",
    )


def test_scanner_sees_every_way_of_writing_a_mark(tmp_path):
    """Literal, module constant, claim-module ID, mark variable, pytestmark, param marks."""
    (tmp_path / "test_styles.py").write_text(
        textwrap.dedent("""
        import pytest
        from reference_impl.claims import table1

        CLAIM = "fig1"
        OTHER = table1.ID
        claim = pytest.mark.claim(CLAIM)

        @pytest.mark.claim("thm1-period")
        def test_literal(): pass

        @pytest.mark.claim(OTHER)
        def test_module_id(): pass

        @claim
        def test_variable(): pass

        @pytest.mark.parametrize("x", [pytest.param(1, marks=pytest.mark.claim("sec9-power-law"))])
        def test_param(x): pass

        class TestGroup:
            pytestmark = [pytest.mark.claim("thm2-harmonic")]
            def test_in_class(self): pass

        @pytest.mark.claim(UNDEFINED)
        def test_unresolved(): pass
    """)
    )
    (tmp_path / "test_module_mark.py").write_text(
        'import pytest\npytestmark = pytest.mark.claim("sec7-effective-mass")\ndef test_a(): pass\n'
    )
    got = {(m.claim, m.test) for m in _scan.scan_claim_marks(tmp_path)}
    want = {
        ("thm1-period", "test_literal"),
        ("table1", "test_module_id"),
        ("fig1", "test_variable"),
        ("sec9-power-law", "test_param"),
        ("thm2-harmonic", "test_in_class"),
        (_scan.UNRESOLVED, "test_unresolved"),
        ("sec7-effective-mass", "test_a"),
    }
    assert_true(
        want <= got,
        got=f"{sorted(got, key=str)}",
        should=f"{sorted(want, key=str)}",
        claim="meta",
        call="scan_claim_marks(tmp)",
    )


def test_refuted_measurement_needs_a_counterexample():
    """The verdict type refuses a refutation without its counterexample, and bad verdicts."""
    for kwargs in ({"verdict": "refuted"}, {"verdict": "maybe"}):
        try:
            Measurement(claim="x", evidence="e", rule="r", **kwargs)
        except ValueError:
            continue
        raise AssertionError(
            f"got Measurement({kwargs}) accepted, should be a ValueError [meta, Measurement]"
        )
    m = Measurement("x", "refuted", "ev; more", "r", {"a": float("nan")}, {"case": 1})
    d = m.to_dict()
    assert_true(
        d["measured"] == {"a": None}
        and d["headline"] == "ev"
        and d["counterexample"] == {"case": 1},
        got=f"{d}",
        should="JSON-ready dict",
        claim="meta",
        call="Measurement.to_dict",
    )
