"""Every built-in code is declared once, in its adapter, and everything else follows
(issue 37, item 3): the registry (`builtin_codes`) gives the report's side-by-side
variants, CI's and nox's install lines, the pytest markers (conftest.py) and the code
names; a registered built-in adapter whose test module, marker, install line or docs
row is missing fails here, and an adapter module declaring a code that the registry
lacks fails too. No list of code names is written here: each check reads the registry
and the adapters' modules, so a new code needs no line in this file.

On main the lists were hand-written in six places (bench/codes.py, .ci/run, noxfile.py,
the pytest plugin's help and two test modules) and nothing checked them.
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from reference_impl.adapters import registry
from reference_impl.adapters.base import CodeInfo, ContactAdapter
from reference_impl.adapters.registry import builtin_codes, parse_spec, resolve_class
from reference_impl.bench import codes as bench_codes

from .assertions import assert_true

ROOT = Path(__file__).resolve().parent.parent
ADAPTERS = ROOT / "reference_impl" / "adapters"
_CALL = "builtin_codes()"
_CLAIM = "issue 37 item 3"


def _checkout(pytestconfig) -> dict:
    """What `_missing` reads: the pip extras of pyproject.toml, the markers pytest knows
    (conftest.py declares the codes' from the registry), .ci/run and docs/crosswalk.md."""
    py = tomllib.loads((ROOT / "pyproject.toml").read_text())
    return {
        "extras": py["project"]["optional-dependencies"],
        "markers": [m.split(":", 1)[0] for m in pytestconfig.getini("markers")],
        "ci": (ROOT / ".ci" / "run").read_text(),
        "crosswalk": (ROOT / "docs" / "crosswalk.md").read_text(),
    }


def _missing(name: str, info: CodeInfo, files: dict) -> list[str]:
    """What a built-in code lacks: its test module (using its marker), the marker
    declared to pytest, an install line (a pip extra of pyproject.toml or a Debian
    package, and .ci/run installing the registry's lists), a row in docs/crosswalk.md,
    report variants of its own adapter. ``files``: `_checkout` (or a changed copy)."""
    out = []
    test = ROOT / info.test_module if info.test_module else None
    if test is None or not test.is_file():
        out.append(f"test module {info.test_module!r}")
    elif not re.search(rf"pytest\.mark\.{re.escape(info.marker)}\b", test.read_text()):
        out.append(f"marker {info.marker!r} in {info.test_module}")
    if not info.marker or info.marker not in files["markers"]:
        out.append(f"marker {info.marker!r} declared to pytest")
    if not ((info.extra and info.extra in files["extras"]) or info.apt):
        out.append(f"install extra {info.extra!r} in pyproject.toml (or an apt package)")
    ci = files["ci"]
    if not ("adapters.registry extras" in ci and "adapters.registry apt" in ci):
        out.append(".ci/run installing the registry's extras and apt packages")
    if f"**{info.code}**" not in files["crosswalk"]:
        out.append(f"a **{info.code}** row in docs/crosswalk.md")
    if not info.report_variants or any(parse_spec(s)[0] != name for s, _ in info.report_variants):
        out.append(f"report variants of {name} ({info.report_variants!r})")
    return out


def _declared_codes() -> dict[str, type]:
    """name -> class of every adapter class in reference_impl/adapters/*.py that declares
    its own `CodeInfo` (in its class body), found by importing the modules."""
    out = {}
    for path in sorted(ADAPTERS.glob("*.py")):
        if path.name.startswith("_"):
            continue
        module = importlib.import_module(f"reference_impl.adapters.{path.stem}")
        for _, cls in inspect.getmembers(module, inspect.isclass):
            if (
                issubclass(cls, ContactAdapter)
                and cls.__module__ == module.__name__
                and isinstance(cls.__dict__.get("code_info"), CodeInfo)
            ):
                out[cls.name] = cls
    return out


def test_every_adapter_module_that_declares_a_code_is_registered():
    """The registry holds every code an adapter module declares (a forgotten registry
    line fails here), under the adapter's own name, and nothing else."""
    declared = _declared_codes()
    codes = builtin_codes()
    wrong = sorted(
        set(declared) ^ set(codes) | {n for n in codes if resolve_class(n) is not declared.get(n)}
    )
    assert_true(
        bool(codes) and not wrong,
        got=f"registered {list(codes)}, declared in modules {sorted(declared)}",
        should="the same codes, each its module's class",
        claim=_CLAIM,
        call=_CALL,
    )


@pytest.mark.parametrize("name", list(builtin_codes()))
def test_every_builtin_code_has_its_test_marker_install_and_docs_row(name, pytestconfig):
    lacks = _missing(name, builtin_codes()[name], _checkout(pytestconfig))
    assert_true(not lacks, got=lacks, should="nothing missing", claim=_CLAIM, call=name)


def test_a_builtin_code_missing_its_parts_fails(monkeypatch, pytestconfig):
    """The check above can fail: a code registered without any of its parts."""

    class Bare(ContactAdapter):
        name = "bare"
        code_info = CodeInfo(
            code="Bare", restitution_input="e", report_variants=(("bare[x]", 1.0),),
            extra="bare", marker="bare", test_module="verification/test_bare.py",
        )  # fmt: skip

    monkeypatch.setitem(registry._REGISTRY, "bare", Bare)
    monkeypatch.setattr(registry, "_BUILTIN", (*registry._BUILTIN, "bare"))
    lacks = _missing("bare", builtin_codes()["bare"], _checkout(pytestconfig))
    for part in ("test module", "declared to pytest", "install extra", "crosswalk"):
        assert_true(any(part in x for x in lacks), got=lacks, should=f"names the missing {part}",
                    claim=_CLAIM, call="_missing(bare)")  # fmt: skip


def _drop_row(text: str, code: str) -> str:
    return "\n".join(ln for ln in text.splitlines() if f"**{code}**" not in ln)


def _unmarked_module(info: CodeInfo, tmp: Path) -> CodeInfo:
    """``info`` with its test module replaced by a copy without its marker."""
    path = tmp / "test_unmarked.py"
    text = (ROOT / info.test_module).read_text()
    path.write_text(re.sub(rf"pytest\.mark\.{re.escape(info.marker)}\b", "pytest.mark.other", text))
    return dataclasses.replace(info, test_module=str(path))


@pytest.mark.parametrize("name", list(builtin_codes()))
def test_each_part_removed_alone_is_named(name, pytestconfig, tmp_path):
    """For a real code, each part taken away alone (test module, its marker, the marker's
    declaration, the pip extra, .ci/run's install line, the crosswalk row) is named."""
    info, files = builtin_codes()[name], _checkout(pytestconfig)
    no_extra = {k: v for k, v in files["extras"].items() if k != info.extra}
    cases = {
        "test module": (dataclasses.replace(info, test_module="verification/none.py"), {}),
        f"marker {info.marker!r} in": (_unmarked_module(info, tmp_path), {}),
        "declared to pytest": (info, {"markers": [m for m in files["markers"] if m != info.marker]}),
        ".ci/run": (info, {"ci": files["ci"].replace("adapters.registry extras", "")}),
        "crosswalk": (info, {"crosswalk": _drop_row(files["crosswalk"], info.code)}),
    }  # fmt: skip
    if info.extra and not info.apt:
        cases["install extra"] = (info, {"extras": no_extra})
    for part, (changed, swap) in cases.items():
        lacks = _missing(name, changed, {**files, **swap})
        assert_true(
            len(lacks) == 1 and part in lacks[0],
            got=lacks,
            should=f"exactly the missing {part}",
            claim=_CLAIM,
            call=f"_missing({name}) without its {part}",
        )


def test_side_by_side_variants_come_from_the_registry():
    want = tuple((i.code, s, p) for i in builtin_codes().values() for s, p in i.report_variants)
    assert_true(bench_codes.CODES == want, got=bench_codes.CODES, should=want, claim=_CLAIM,
                call="bench.codes.CODES")  # fmt: skip


def test_install_lists_from_the_registry():
    """What .ci/run and nox install is what the codes declare, each once, from pip or
    Debian (never both); the noxfile names no code by hand."""
    infos = builtin_codes().values()
    extras, apt = registry.install_extras(), registry.apt_packages()
    one_way = all(bool(i.extra) != bool(i.apt) for i in infos)
    printed = {
        what: subprocess.run(
            [sys.executable, "-m", "reference_impl.adapters.registry", what],
            capture_output=True, text=True, cwd=ROOT, check=True,
        ).stdout.split()
        for what in ("extras", "apt")
    }  # fmt: skip
    assert_true(
        one_way
        and extras == [i.extra for i in infos if i.extra]
        and apt == [i.apt for i in infos if i.apt]
        and printed == {"extras": extras, "apt": apt},
        got=f"extras {extras}, apt {apt}, printed {printed}",
        should="each code's own extra or apt package, once, as the module prints them",
        claim=_CLAIM,
        call="install_extras(), apt_packages()",
    )
    nox = (ROOT / "noxfile.py").read_text()
    for name in builtin_codes():
        assert_true(f'"{name}"' not in nox and f"'{name}'" not in nox, got=f"{name!r} in noxfile.py",
                    should="no hand-written code names (the registry's)", claim=_CLAIM,
                    call="noxfile.py")  # fmt: skip
