"""Shared helpers of the report: number formatting and JSON conversion."""

from __future__ import annotations

from reference_impl._format import g, jsonable

__all__ = ["g", "jsonable"]
