"""The package's shape: layers import only downward, and no module imports itself back.

Every import of ``reference_impl`` is read from the source (AST), deferred imports inside
functions included, and checked against the layer order below; a cycle between modules
(or between the rooms of one layer) fails too. ``test_planted_violation_is_caught`` runs the
same checker on a small package made in a temporary directory, so the check can fail.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PKG = "reference_impl"
ROOT = Path(__file__).resolve().parent.parent / PKG

# Bottom to top. A room (a top-level module or sub-package of reference_impl) may import
# rooms of lower layers and itself, never a room of a higher layer or another room of its
# own layer. The package face (reference_impl/__init__.py) re-exports public names and is
# the only file above every layer.
LAYERS: tuple[frozenset[str], ...] = tuple(
    frozenset(x)
    for x in (
        {"_version", "_atomic"},
        {"errors", "_numba_dir"},
        {"provenance", "_format", "_jit", "_cache", "_procs", "_userfiles"},
        {"_stored", "_expr_cache"},
        {"potentials"},
        {"theory"},
        {"integrators"},
        {"exact"},
        {"stability"},
        {"assembly"},
        {"scenes"},
        {"tasks"},
        {"studies"},
        {"claims"},
        {"adapters"},
        {"bench"},
        {"sweep"},
        {"report"},
        {"campaign"},
        {"cli", "pytest_plugin"},
    )
)


# The report renders a results dict and computes nothing (issue 30): besides itself it may
# import only these (the claims for their quotes, corrected texts and row classifiers,
# the scorecard formatting of bench.report, the adapter-spec check of report._files, and
# the bottom helpers). The studies, the solvers, the map and the codes run in `campaign`.
RENDER_ONLY = (
    "reference_impl.report",
    "reference_impl.claims",
    "reference_impl.bench.scorecard.report",
    "reference_impl.adapters.registry",
    "reference_impl._format",
    "reference_impl.errors",
    "reference_impl._userfiles",
    "reference_impl._atomic",
)


def _module_name(path: Path, root: Path, pkg: str) -> str:
    parts = [pkg, *path.relative_to(root).with_suffix("").parts]
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _modules(root: Path, pkg: str) -> dict[str, Path]:
    return {_module_name(p, root, pkg): p for p in sorted(root.rglob("*.py"))}


def _resolve(name: str, modules: dict[str, Path]) -> str | None:
    """The longest known module that ``name`` (a dotted import target) lies in."""
    parts = name.split(".")
    for i in range(len(parts), 0, -1):
        cand = ".".join(parts[:i])
        if cand in modules:
            return cand
    return None


def import_edges(root: Path, pkg: str = PKG) -> list[tuple[str, str, int]]:
    """(importer, imported, line) for every import of ``pkg`` inside it, deferred ones too."""
    modules = _modules(root, pkg)
    edges = []
    for mod, path in modules.items():
        is_pkg = path.name == "__init__.py"
        base = mod.split(".") if is_pkg else mod.split(".")[:-1]
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            targets: list[str] = []
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    up = base[: len(base) - (node.level - 1)] if node.level > 1 else base
                    head = ".".join(up + ([node.module] if node.module else []))
                else:
                    head = node.module or ""
                # `from a.b import c` may name the module a.b.c or a name defined in a.b
                targets = [f"{head}.{a.name}" for a in node.names]
            for t in targets:
                if t == pkg or t.startswith(pkg + "."):
                    hit = _resolve(t, modules)
                    if hit and hit != mod:
                        edges.append((mod, hit, node.lineno))
    return edges


def _room(mod: str, pkg: str) -> str | None:
    parts = mod.split(".")
    return parts[1] if len(parts) > 1 else None  # None: the package face


def _layer(room: str, layers) -> int:
    for i, layer in enumerate(layers):
        if room in layer:
            return i
    raise KeyError(room)


def _cycles(edges) -> list[list[str]]:
    """Strongly connected components with more than one member (Tarjan, iterative)."""
    graph: dict[str, set[str]] = {}
    for a, b, _ in edges:
        graph.setdefault(a, set()).add(b)
        graph.setdefault(b, set())
    index, low, on, stack, out, counter = {}, {}, set(), [], [], [0]
    for start in graph:
        if start in index:
            continue
        work = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = counter[0]
        counter[0] += 1
        stack.append(start)
        on.add(start)
        while work:
            v, it = work[-1]
            for w in it:
                if w not in index:
                    index[w] = low[w] = counter[0]
                    counter[0] += 1
                    stack.append(w)
                    on.add(w)
                    work.append((w, iter(sorted(graph[w]))))
                    break
                if w in on:
                    low[v] = min(low[v], index[w])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[v])
                if low[v] == index[v]:
                    comp = []
                    while True:
                        w = stack.pop()
                        on.discard(w)
                        comp.append(w)
                        if w == v:
                            break
                    if len(comp) > 1:
                        out.append(sorted(comp))
    return out


def violations(root: Path, pkg: str = PKG, layers=LAYERS) -> list[str]:
    """Every upward import, unknown room and cycle, as one readable line each."""
    edges = import_edges(root, pkg)
    problems = []
    for a, b, line in edges:
        ra, rb = _room(a, pkg), _room(b, pkg)
        if ra is None or a.endswith(".__main__"):
            continue  # the package face re-exports from every layer; __main__ is an entry point
        if rb is None:
            problems.append(f"{a}:{line} imports the package face {pkg}; import the module")
            continue
        try:
            la, lb = _layer(ra, layers), _layer(rb, layers)
        except KeyError as exc:
            problems.append(f"{a}:{line}: room {exc.args[0]!r} is in no layer of test_layers.py")
            continue
        if ra != rb and lb >= la:
            problems.append(
                f"{a}:{line} imports {b}: layer {lb} ({rb}) is not below layer {la} ({ra})"
            )
    for comp in _cycles(edges):
        problems.append("module cycle: " + " -> ".join(comp))
    room_edges = [
        (_room(a, pkg), _room(b, pkg), 0)
        for a, b, _ in edges
        if _room(a, pkg)
        and _room(b, pkg)
        and _room(a, pkg) != _room(b, pkg)
        and not a.endswith(".__main__")
    ]
    for comp in _cycles(room_edges):
        problems.append("package cycle: " + " -> ".join(comp))
    return problems


def test_every_room_has_a_layer():
    rooms = {p.stem if p.is_file() else p.name for p in ROOT.iterdir()}
    rooms = {r for r in rooms if r not in {"__init__", "__main__", "__pycache__"}}
    rooms = {r for r in rooms if (ROOT / r).is_dir() or (ROOT / f"{r}.py").is_file()}
    known = set().union(*LAYERS)
    assert rooms <= known, (
        f"got rooms {sorted(rooms - known)} outside every layer, should be in one"
    )


def test_imports_run_only_downward_and_never_in_a_circle():
    problems = violations(ROOT)
    assert not problems, "got upward imports or cycles, should be none:\n" + "\n".join(problems)


def render_violations(root: Path, pkg: str = PKG, room: str = "report", allowed=RENDER_ONLY):
    """Imports of ``pkg.room`` (deferred ones too) into anything outside ``allowed``."""

    def inside(name, prefixes):
        return any(name == p or name.startswith(p + ".") for p in prefixes)

    return [
        f"{a}:{line} imports {b}"
        for a, b, line in import_edges(root, pkg)
        if inside(a, [f"{pkg}.{room}"]) and not inside(b, allowed)
    ]


def test_the_report_renders_and_imports_nothing_that_computes():
    problems = render_violations(ROOT)
    assert not problems, (
        "got imports of computing modules from reference_impl/report, should be none "
        "(move the computation to reference_impl/studies or reference_impl/campaign):\n"
        + "\n".join(problems)
    )


def test_planted_computing_import_in_the_report_is_caught(tmp_path):
    root = tmp_path / "pkg"
    _write(root, "__init__.py", "")
    _write(root, "report/__init__.py", "def f():\n    from pkg.exact import solve\n")
    _write(root, "exact/__init__.py", "")
    _write(root, "exact/solve.py", "")
    problems = render_violations(root, "pkg", allowed=("pkg.report",))
    assert problems == ["pkg.report:2 imports pkg.exact.solve"], f"got {problems}"


def _write(root: Path, rel: str, text: str) -> None:
    p = root / rel
    p.parent.mkdir(parents=True, exist_ok=True)
    p.write_text(text)


@pytest.mark.parametrize(
    "planted, expect",
    [
        # a potential importing the exact solver (deferred, inside a function)
        ("def f():\n    from pkg.exact import solve\n", "is not below"),
        # a module importing the package face
        ("import pkg\n", "package face"),
    ],
)
def test_planted_violation_is_caught(tmp_path, planted, expect):
    root = tmp_path / "pkg"
    _write(root, "__init__.py", "")
    _write(root, "potentials/__init__.py", "")
    _write(root, "exact/__init__.py", "")
    _write(root, "exact/solve.py", "from pkg.potentials import base\n")
    _write(root, "potentials/base.py", planted)
    layers = (frozenset({"potentials"}), frozenset({"exact"}))
    problems = violations(root, "pkg", layers)
    assert any(expect in p for p in problems), f"got {problems}, should name {expect!r}"


def test_planted_cycle_is_caught(tmp_path):
    root = tmp_path / "pkg"
    _write(root, "__init__.py", "")
    _write(root, "a.py", "from . import b\n")
    _write(root, "b.py", "def f():\n    from .a import x\n")
    problems = violations(root, "pkg", (frozenset({"a", "b"}),))
    assert any(p.startswith("module cycle") for p in problems), f"got {problems}"


def test_no_module_lists_a_public_name_twice():
    """``__all__`` names each public name once (read with the AST, nothing imported)."""
    twice = {}
    for path in sorted(ROOT.rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if (
                isinstance(node, ast.Assign | ast.AugAssign)
                and isinstance(getattr(node, "target", None) or node.targets[0], ast.Name)
                and (getattr(node, "target", None) or node.targets[0]).id == "__all__"
                and isinstance(node.value, ast.List | ast.Tuple)
            ):
                names = [e.value for e in node.value.elts if isinstance(e, ast.Constant)]
                dup = sorted({n for n in names if names.count(n) > 1})
                if dup:
                    twice[str(path.relative_to(ROOT))] = dup
    assert not twice, f"got {twice}, should be every name once [tool, __all__]"


def test_no_test_module_imports_another():
    """Test modules share constants and helpers through helper modules (``verification/_*.py``),
    never by importing another test module (which runs its module body, and ties a tool test
    to a claim module's internals)."""
    here = Path(__file__).resolve().parent
    found = []
    for path in sorted(here.glob("test_*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom):
                names = [node.module or ""] + [f"{node.module or ''}.{a.name}" for a in node.names]
            elif isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            else:
                continue
            if any(n.rsplit(".", 1)[-1].startswith("test_") for n in names):
                found.append(f"{path.name}:{node.lineno}")
    assert not found, f"got test modules importing test modules at {found}, should be none"


# Function-level imports of the package allowed outside the PEP 562 faces and the pytest
# plugin (issue 30: 152 of them before; the lazy boundary is the command a user names,
# below it imports sit at the top of modules; what stays deferred keeps a start-up goal of
# verification/test_startup.py, or sits in an if/try branch).
MAX_DEFERRED = 60


def _imports_in_functions(node, in_function: bool, faces: set[int]):
    """Import nodes inside a function (not one of ``faces``) below ``node``."""
    for child in ast.iter_child_nodes(node):
        if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef):
            if id(child) not in faces:
                yield from _imports_in_functions(child, True, faces)
        elif isinstance(child, ast.Import | ast.ImportFrom):
            if in_function:
                yield child
        else:
            yield from _imports_in_functions(child, in_function, faces)


def deferred_imports(root: Path, pkg: str = PKG) -> list[str]:
    """``module:line`` of every import of ``pkg`` inside a function, except in a module's
    ``__getattr__``/``__dir__`` (PEP 562) and in the pytest plugin (which every pytest run
    loads). Imports of other packages (numerical libraries, optional extras) are not counted."""
    found = []
    for mod, path in _modules(root, pkg).items():
        if mod == f"{pkg}.pytest_plugin":
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
        faces = {
            id(n)
            for n in tree.body
            if isinstance(n, ast.FunctionDef) and n.name in ("__getattr__", "__dir__")
        }
        base = mod.split(".") if path.name == "__init__.py" else mod.split(".")[:-1]
        for node in _imports_in_functions(tree, False, faces):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif node.level:
                up = base[: len(base) - (node.level - 1)] if node.level > 1 else base
                names = [".".join(up + ([node.module] if node.module else []))]
            else:
                names = [node.module or ""]
            if any(n == pkg or n.startswith(pkg + ".") for n in names):
                found.append(f"{mod}:{node.lineno}")
    return found


def test_deferred_imports_of_the_package_are_few():
    found = deferred_imports(ROOT)
    assert len(found) <= MAX_DEFERRED, (
        f"got {len(found)} function-level imports of {PKG}, should be <= {MAX_DEFERRED} "
        f"(move them to the top of their modules) [tool, deferred imports]: {found}"
    )


def test_planted_deferred_imports_are_counted(tmp_path):
    root = tmp_path / "pkg"
    _write(root, "__init__.py", "def __getattr__(name):\n    from pkg import a\n")
    _write(root, "a.py", "import os\n\ndef f():\n    import json\n    from pkg import b\n")
    _write(root, "b.py", "class C:\n    def m(self):\n        from . import a\n")
    got = sorted(deferred_imports(root, "pkg"))
    assert got == ["pkg.a:5", "pkg.b:3"], f"got {got}, should be ['pkg.a:5', 'pkg.b:3']"


def test_the_run_writes_its_json_without_importing_the_renderer():
    # Issue 37 item 4: the renderer only renders. Every module the runner imports, directly
    # or through others (read from the source, deferred imports too), is checked.
    graph: dict[str, set[str]] = {}
    for a, b, _ in import_edges(ROOT):
        graph.setdefault(a, set()).add(b)
    seen, todo = set(), ["reference_impl.bench.scorecard.runner"]
    while todo:
        for nxt in graph.get(todo.pop(), ()):
            if nxt not in seen:
                seen.add(nxt)
                todo.append(nxt)
    renderer, writer = (
        "reference_impl.bench.scorecard.report",
        "reference_impl.bench.scorecard._json",
    )
    reached = sorted(m for m in seen if m.startswith(renderer))
    assert not reached and writer in seen, (
        f"got the runner reaching {reached} (and {writer}: {writer in seen}), should be no "
        "renderer and the JSON writer reached [layers, import_edges(bench.scorecard.runner)]"
    )


# The rooms of bench/ (issue 37 item 4), bottom to top: the ground every study stands on,
# the scorecard, calibration and the assembly codes' worker (`_code_worker`, issue 39)
# side by side (none imports another), the codes studies (`codes`, which calibrates;
# `assembly_codes`, whose codes run in that worker). bench/__init__.py, the face,
# re-exports and stands above them all.
BENCH_ROOMS: tuple[frozenset[str], ...] = tuple(
    frozenset(x)
    for x in (
        {"measure", "worker"},
        {"scorecard", "calibration", "_code_worker"},
        {"codes", "assembly_codes"},
    )
)


def test_the_rooms_of_bench_import_only_downward():
    def room(mod: str) -> str | None:
        parts = mod.split(".")
        return parts[2] if parts[:2] == [PKG, "bench"] and len(parts) > 2 else None

    bad = []
    for a, b, line in import_edges(ROOT):
        ra, rb = room(a), room(b)
        if ra is None or rb is None or ra == rb:
            continue
        la, lb = _layer(ra, BENCH_ROOMS), _layer(rb, BENCH_ROOMS)
        if lb >= la:
            bad.append(f"{a}:{line} -> {b}")
    assert not bad, (
        f"got bench rooms importing sideways or up: {bad}, should be none [layers, bench/]"
    )
