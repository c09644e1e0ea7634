"""Nox sessions: tests, lint, bench, report, docs.

``nox -s tests`` runs the suite with the CI hypothesis profile (``nox -s tests-latest``: on
the newest release of every dependency, for Python 3.11 to 3.13); ``nox -s bench``
prints speed ratios measured in one process (never timed inside tests).
"""

from __future__ import annotations

import nox

nox.options.sessions = ["tests", "lint"]
nox.options.default_venv_backend = "venv"


@nox.session(python="3.11")
def tests(session: nox.Session) -> None:
    """Run the verification suite (hypothesis profile 'ci')."""
    _install_with_codes(session, "test,sweep")
    # Two workers (the CI machine's cores); a module's tests stay in one worker, so its
    # fixtures (the shared quick report) are built once.
    args = session.posargs or ["-n", "2", "--dist", "loadfile"]
    session.run("python", "-m", "pytest", *args, env={"HYPOTHESIS_PROFILE": "ci"})


def _registry(session: nox.Session, what: str) -> list[str]:
    """The built-in codes' ``names`` or pip ``extras``, from the adapter registry
    (`reference_impl.adapters.registry.builtin_codes`: the one list of the codes)."""
    out = session.run("python", "-m", "reference_impl.adapters.registry", what, silent=True)
    return (out or "").split()


def _install_with_codes(session: nox.Session, extras: str, *flags: str) -> None:
    """Install the package with ``extras``, then with every contact code's extra too."""
    session.install(*flags, "-e", f".[{extras}]")
    codes = ",".join(_registry(session, "extras"))
    session.install(*flags, "-e", f".[{extras},{codes}]")


@nox.session(python=["3.11", "3.12", "3.13"], name="tests-latest")
def tests_latest(session: nox.Session) -> None:
    """The suite on the newest releases of every dependency that pyproject.toml allows.

    ``pip install --upgrade --upgrade-strategy eager`` takes the newest release of each
    dependency, direct or not, within the declared bounds (``tests`` keeps whatever the
    resolver picks first). The versions are printed first, so that a failure names the
    stack it happened on. An interpreter that is not installed is skipped by nox
    (``nox -s tests-latest-3.12`` runs one).
    """
    _install_with_codes(session, "test,sweep", "--upgrade", "--upgrade-strategy", "eager")
    session.run("python", "-m", "pip", "list", "--format=freeze")
    args = session.posargs or ["-n", "2", "--dist", "loadfile"]
    session.run("python", "-m", "pytest", *args, env={"HYPOTHESIS_PROFILE": "ci"})


# What `nox -s lint` (and verification/test_format.py, in every test run) holds to ruff.
LINT_PATHS = (
    "reference_impl",
    "verification",
    "benchmarks",
    "reports/repro",
    "noxfile.py",
    "conftest.py",
    "docs/conf.py",
)
# The formatter's output changes between ruff releases: one pinned version (also in the
# [test] extra), so that a check that passes here passes in CI.
RUFF = "ruff==0.17.6"


@nox.session(python="3.11")
def lint(session: nox.Session) -> None:
    """ruff over the package, the suite, the benchmarks and the referee's scripts: the
    linter's rules and the formatter (``ruff format --check``)."""
    session.install(RUFF)
    session.run("ruff", "check", *LINT_PATHS)
    session.run("ruff", "format", "--check", *LINT_PATHS)


@nox.session(python="3.11")
def bench(session: nox.Session) -> None:
    """Speed against a baseline run in the same process; results as JSON in reports/bench/."""
    _install_with_codes(session, "sweep")
    session.run("python", "-m", "benchmarks.bench_exact", "--json", "reports/bench/exact.json")
    session.run(
        "python",
        "-m",
        "benchmarks.bench_workprecision",
        "--json",
        "reports/bench/workprecision.json",
        "--png",
        "reports/bench/workprecision.png",
    )
    # solve_impacts against the fastest peer in a compiled parallel loop (issue 38, goal 5).
    session.run(
        "python", "-m", "benchmarks.bench_batch_peer", "--json", "reports/bench/batch_peer.json"
    )
    session.run("python", "-m", "benchmarks.bench_verlet", "--json", "reports/bench/verlet.json")
    session.run(
        "python", "-m", "benchmarks.bench_assembly", "--json", "reports/bench/assembly.json"
    )
    session.run("python", "-m", "benchmarks.bench_lammps", "--json", "reports/bench/lammps.json")
    session.run("python", "-m", "benchmarks.bench_sweep", "--json", "reports/bench/sweep.json")
    session.run(
        "python", "-m", "benchmarks.bench_sweep_assembly", "--json",
        "reports/bench/sweep_assembly.json",
    )  # fmt: skip
    session.run("python", "-m", "benchmarks.bench_startup", "--json", "reports/bench/startup.json")
    # The records of the docs' other figures (issue 41), then the pages' blocks from them.
    session.run(
        "python", "-m", "benchmarks.bench_startup", "--docs", "--repeats", "1",
        "--json", "reports/bench/commands.json",
    )  # fmt: skip
    session.run("python", "-m", "benchmarks.bench_codes", "--json", "reports/bench/codes.json")
    session.run("python", "-m", "reference_impl.report.docs_blocks")


@nox.session(python="3.11")
def report(session: nox.Session) -> None:
    """Generate the verification report into reports/ (``nox -s report -- --quick`` for CI)."""
    session.install("-e", ".[report,test]")
    session.run("hcv", "report", *session.posargs)
    session.run(
        "python", "-m", "pytest", "verification/test_report.py", env={"HYPOTHESIS_PROFILE": "ci"}
    )


@nox.session(python="3.11", name="assemblies-1e6")
def assemblies_1e6(session: nox.Session) -> None:
    """The assemblies claim's 1e6-step record, reports/assemblies_1e6.json (issue 39; ~20 min
    of CPU on 2 workers); the report reads it and never rewrites it. Commit the file."""
    session.install("-e", ".[sweep]")
    session.run("python", "-m", "reference_impl.campaign.assembly_long", *session.posargs)


@nox.session(python="3.11", name="committed-report")
def committed_report(session: nox.Session) -> None:
    """The report committed in reports/: from a clean commit, with every built-in code (the registry's: LAMMPS, Kratos, MuJoCo, Drake, PyBullet,
    LIGGGHTS and YADE) side by side (the last two from Debian: apt-get install liggghts yade), so that its provenance names HEAD without "uncommitted changes" (issue 17).

    Refuses to run on a dirty work tree; commit (or stash) first, then commit what it
    rewrites (reports/ and the README's generated blocks).
    """
    dirty = session.run("git", "status", "--porcelain", silent=True, external=True)
    if dirty and dirty.strip():
        session.error("the work tree has uncommitted changes; commit or stash them first")
    _install_with_codes(session, "report,test")
    adapters = [a for name in _registry(session, "names") for a in ("--adapter", name)]
    session.run("hcv", "report", *adapters)


@nox.session(python="3.11")
def docs(session: nox.Session) -> None:
    """Build the documentation site into docs/_build/html, every warning an error."""
    session.install("-e", ".[docs]")
    session.run(
        "python",
        "-m",
        "sphinx",
        "-W",
        "--keep-going",
        "-b",
        "html",
        "docs",
        "docs/_build/html",
        *session.posargs,
    )
