"""pytest plugin: benchmark a contact code from its own test suite.

Installed as the ``pytest11`` entry point ``hcv-contact``, so a code's CI runs::

    pytest --contact-adapter=package.module:Class [--contact-scenes=hertz,hertz-damped]
           [--contact-tolerances=tol.toml] [--contact-json=bench.json]

and gets one test per adapter variant, scene and scorecard metric, named
``contact-adapter/<variant>/<scene>::<metric>``: a failed metric fails its test
with the scorecard's one-line explanation, a metric that does not apply (or a
scene the code declines) is skipped, and a metric the suite's own reference
could not decide (status "error") fails with "internal error of the reference
(ours ...)" (a `ContactReferenceError`, never reported as the code's
`ContactMetricFailure`). The benchmark (`reference_impl.bench.run_bench`) runs
once, when the first of these tests runs. Without ``--contact-adapter`` the plugin does nothing.
Any adapter spec of ``hcv bench`` works (a registered name, ``cmd:COMMAND``, ...).
"""

from __future__ import annotations

import pytest

_RESULT_KEY = pytest.StashKey[object]()


def pytest_addoption(parser):
    group = parser.getgroup(
        "contact-adapter",
        "benchmark a contact code against the exact solution (hidden-harmonic-verification)",
    )
    group.addoption(
        "--contact-adapter",
        default=None,
        metavar="SPEC",
        help="adapter to benchmark: package.module:Class, a registered name "
        "(hcv bench --help lists them; variants as kratos[hertz,verlet] or "
        "lammps[tsuji]) or cmd:COMMAND",
    )
    group.addoption(
        "--contact-scenes",
        default=None,
        metavar="S1,S2",
        help="comma-separated scene names or TOML files (default: the bench's)",
    )
    group.addoption(
        "--contact-tolerances",
        default=None,
        metavar="FILE",
        help="TOML file overriding the default tolerances",
    )
    group.addoption(
        "--contact-json",
        default=None,
        metavar="FILE",
        help="also write the JSON report of the benchmark here",
    )


def _scenes(config):
    text = config.getoption("contact_scenes")
    if text is None:
        return None
    names = [s.strip() for s in text.split(",") if s.strip()]
    if not names:
        raise pytest.UsageError(f"--contact-scenes={text!r} names no scene")
    return names


class ContactMetricFailure(AssertionError):
    """A scorecard metric failed (the message is its one-line explanation)."""


class ContactReferenceError(RuntimeError):
    """The suite's own reference could not decide this metric (not the code's failure)."""


class ContactMetricItem(pytest.Item):
    """One scorecard metric of one adapter variant on one scene."""

    def __init__(self, *, variant: str, scene: str, metric: str, **kw):
        super().__init__(**kw)
        self.variant, self.scene, self.metric = variant, scene, metric

    def runtest(self):
        result = _bench(self.config)
        if isinstance(result, Exception):
            raise ContactMetricFailure(f"the benchmark could not run: {result}")
        for m in result.metrics:
            if (m.variant, m.scene, m.metric) == (self.variant, self.scene, self.metric):
                if m.status in ("skip", "n/a"):
                    pytest.skip(m.explanation)
                if m.status == "fail":
                    raise ContactMetricFailure(m.explanation)
                if m.status == "error":
                    raise ContactReferenceError(m.explanation)
                return
        raise ContactMetricFailure("no result for this metric (benchmark interrupted?)")

    def repr_failure(self, excinfo):
        if isinstance(excinfo.value, (ContactMetricFailure, ContactReferenceError)):
            return f"{self.metric} [{self.variant} / {self.scene}]: {excinfo.value}"
        return super().repr_failure(excinfo)

    def reportinfo(self):
        return self.path, None, f"{self.variant}/{self.scene}::{self.metric}"


class ContactAdapterCollector(pytest.Collector):
    """Collects the metric items of one adapter (no file behind it)."""

    def collect(self):
        from reference_impl.adapters.base import AdapterScene
        from reference_impl.adapters.registry import get_adapter
        from reference_impl.bench.scorecard.metrics import metric_names
        from reference_impl.bench.scorecard.runner import resolve_scenes
        from reference_impl.errors import HCVInputError

        spec = self.config.getoption("contact_adapter")
        try:
            adapter = get_adapter(spec)
            variants = adapter.variants()
            scenes = resolve_scenes(_scenes(self.config))
        except HCVInputError as exc:
            raise pytest.UsageError(f"--contact-adapter={spec}: {exc}") from None
        for var in variants:
            for sc in scenes:
                probe = AdapterScene.from_scene(sc, sc.velocities[0], 1.0, 1)
                if var.supports(probe):
                    continue
                for metric in metric_names():
                    yield ContactMetricItem.from_parent(
                        self,
                        name=f"{var.label}/{sc.name}::{metric}",
                        variant=var.label,
                        scene=sc.name,
                        metric=metric,
                    )
        adapter.close()


def _bench(config):
    result = config.stash.get(_RESULT_KEY, None)
    if result is None:
        from reference_impl.bench.scorecard.runner import run_bench
        from reference_impl.errors import HCVInputError

        try:
            result = run_bench(
                config.getoption("contact_adapter"),
                scenes=_scenes(config),
                tolerances=config.getoption("contact_tolerances"),
                json_path=config.getoption("contact_json"),
            )
        except HCVInputError as exc:
            result = exc
        config.stash[_RESULT_KEY] = result
    return result


def pytest_collection_modifyitems(session, config, items):
    if not config.getoption("contact_adapter"):
        return
    collector = ContactAdapterCollector.from_parent(session, name="contact-adapter")
    items.extend(collector.collect())
