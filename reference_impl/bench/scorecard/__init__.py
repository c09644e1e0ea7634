"""The scorecard (``hcv bench``): scenes through an adapter and through the exact solution,
the metrics and their rules, the tolerances, and the JSON, JUnit and rendered reports.

`runner.run_bench` is the entry point; its public names are importable from
`reference_impl.bench`.
"""

__all__: list[str] = []
