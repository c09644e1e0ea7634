"""Machine and commit information printed with every benchmark result."""

from reference_impl.provenance import machine_info

__all__ = ["machine_info"]
