"""How much a code's calibrated quantity moves between identical runs (issue 36 item 7).

A code whose output carries noise (a random initial state, threads summing in any order)
answers the same option value with a different restitution each run. The bracketed
search of `reference_impl.bench.calibration.calibrate` then stops where the noisy sign of
``measured - target`` changes, which misses the target by about the noise, not by the
root tolerance: read as a jump of the response, that was "out of reach". `spread_at`
repeats the run at such a point and measures the noise; `within_noise` says whether the
point meets the target within it.
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Callable
from dataclasses import dataclass

__all__ = ["REPEATS", "SIGMAS", "Spread", "spread_at", "within_noise"]

# Runs at a point whose noise is measured (the first included): the sample standard
# deviation of 8 draws is within a factor 0.5-1.5 of the true one at 95 % confidence
# (chi distribution, 7 degrees of freedom): enough to tell noise of 1e-4 from a jump.
REPEATS = 8
# A point meets the target within the noise when the mean of its runs is within this many
# standard deviations of one run: the search stops where the noisy sign of (measured -
# target) changes, i.e. where the response is within a few noise widths of the target,
# while a jump of the response misses by its own size.
SIGMAS = 3.0


@dataclass(frozen=True)
class Spread:
    """The quantity over repeated identical runs at one option value.

    Attributes
    ----------
    x : float
        The option value.
    values : tuple of float
        The quantity of each run (dimensionless restitution; NaN for a failed run).
    """

    x: float
    values: tuple

    @property
    def finite(self) -> list:
        return [v for v in self.values if math.isfinite(v)]

    @property
    def mean(self) -> float:
        return statistics.fmean(self.finite) if self.finite else math.nan

    @property
    def std(self) -> float:
        """Sample standard deviation of one run (0 when every run gave the same value)."""
        return statistics.stdev(self.finite) if len(self.finite) > 1 else 0.0

    @property
    def noisy(self) -> bool:
        """The runs differ: the code does not repeat itself."""
        return len(set(self.finite)) > 1


def spread_at(x: float, first: float, run_once: Callable[[], float]) -> Spread:
    """Repeat the run at ``x`` (``first`` is the value already measured there).

    One repeat decides: an identical value is a deterministic code (no more runs); a
    different one starts the `REPEATS` runs whose spread is the noise.

    Parameters
    ----------
    x : float
        The option value.
    first : float
        The quantity of the run already made at ``x``.
    run_once : callable
        A fresh run at ``x`` (not a cached one), returning the quantity.
    """
    values = [first, run_once()]
    if values[1] == values[0]:
        return Spread(x, tuple(values))
    values += [run_once() for _ in range(REPEATS - 2)]
    return Spread(x, tuple(values))


def within_noise(spread: Spread, target: float, atol: float) -> bool:
    """The mean at the point is within max(``atol``, `SIGMAS` x noise) of ``target``."""
    return spread.noisy and abs(spread.mean - target) <= max(atol, SIGMAS * spread.std)
