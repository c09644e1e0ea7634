"""The contact potential base class and the sum of potentials.

A potential is the one physical object of section 3 of the paper: a scalar
U(q) on the overlap q >= 0 (metres, joules) with U(0) = 0, U' > 0 and a unique
turning point q_max(E) for each energy E > 0.
"""

from __future__ import annotations

import math
import sys
from abc import ABC, abstractmethod
from typing import Any, ClassVar

import numpy as np

from reference_impl.errors import DomainError, HCVInputError, NonMonotoneError, NoTurningPointError
from reference_impl.potentials._terms import term_rows

__all__ = ["Potential", "SumPotential", "is_mp"]

# Grid used by `check_monotone`: log-spaced points resolve the q -> 0 end, linear
# ones the rest of (0, q_max]. A grid cannot prove positivity, so potentials that
# know better (power laws) override the check.
_MONOTONE_LOG_POINTS = 600
_MONOTONE_LIN_POINTS = 2000
# Root tolerance for the numeric inverse of U: a few ulps of log q, i.e. of q.
_INVERSE_XRTOL = 4.0 * np.finfo(float).eps
# Newton iterations allowed; quadratic convergence needs ~5, bisection fallbacks more.
_NEWTON_MAX_ITER = 200
# The bracket search doubles/halves at most this often (2**±1100 spans float64).
_MAX_BRACKET_STEPS = 1100


def is_mp(q: Any) -> bool:
    """Return True when ``q`` is an mpmath number (the high-precision path)."""
    # Without mpmath loaded no mpmath number can exist: a float solve never imports it
    # (45 ms of start-up, issue 20).
    mp = sys.modules.get("mpmath")
    return mp is not None and isinstance(q, (mp.mpf, mp.mpc))


class Potential(ABC):
    """Base class of a monotone one-dimensional contact potential U(q).

    Contract for implementers (numbered, as the rest of the package relies on it):

    1. Implement ``_U(q)``, ``_dU(q)`` and ``_d2U(q)``. They receive either a
       float64 ``numpy.ndarray`` with every entry in ``[0, q_sup]`` or one
       ``mpmath.mpf``, and return the same kind. Use only arithmetic, ``**`` and
       the namespace returned by ``self._ns(q)`` (``numpy`` or ``mpmath``), so
       that one formula serves both the float64 and the 50-digit path.
    2. Set ``leading_exponent``: the n > 0 with U(q) ~ c q**n as q -> 0+,
       decided exactly (from the family's formula, or by sympy for an
       `Expression`; never from a float evaluation near 0), and
       ``leading_coefficient``: that c (J/m**n) as a float, or None when the
       family does not know it. The quadratures of `reference_impl.exact.solve`
       substitute with n to remove the endpoint singularity of dq/dx;
       `reference_impl.stability.bound` takes the limit of U'/sqrt(2U) at 0 from
       (n, c). These two names are a stable interface.
    3. Set ``q_sup`` (metres) when U is defined only on ``[0, q_sup]``; the
       public methods raise `DomainError` outside it.
    4. Optionally override ``_inverse(u)`` with an exact inverse of U on
       arrays; the default is a bracketed root finder (a few ulps accurate).
    5. Set ``q_scale`` (metres), a typical overlap, used as the starting point of
       bracket searches.
    6. Implement ``params()`` returning the defining parameters as a dict.
    7. To be a scene family (``[potential] family = NAME``), set ``family`` (NAME),
       ``scene_keys`` ((required, optional) keys of its table) and ``label`` (one
       line naming the law, with units), and decorate the class with
       `reference_impl.potentials.register_family`. The default ``from_scene``
       passes each key, read as a positive finite number, to the constructor by
       name; ``scene_params`` (default ``params()``) is the table it writes back.
       Override both when the table holds other kinds of value.
    8. For compiled speed, implement ``_term_rows()``: the family's rows of the term
       table (`reference_impl.potentials._terms`: powers k q^n / n, volumetric caps,
       the saturating force), or None when U is not such a sum (the default). It is
       the one place the compiled kernels learn a family from: the exact solver's
       node loops and the velocity-Verlet lanes both read the table through
       `reference_impl.potentials._terms.term_rows`. Only a hook defined in the
       class's own body counts: a subclass inherits no table (it may change the
       law) unless its body opts in, ``_term_rows = Parent._term_rows``. Without
       a table the family runs on the numpy paths.

    The public methods ``U``, ``dU``, ``d2U`` validate the input (NaN, q < 0,
    q > q_sup) and then call the hooks. The float64 hooks must be accurate to
    a few ulps (relative) at every q, including q -> 0 where a formula such as
    q - atan(q) cancels: evaluate there by a series or at raised precision.

    Stable interface for exact (symbolic) solvers: a potential given as a
    formula, `reference_impl.potentials.Expression`, also exposes
    ``sympy_U`` (the validated U as a sympy expression, parameters substituted
    by exact numbers, every ``abs`` resolved for q > 0) and ``sympy_symbol``
    (the real sympy symbol of q in it).
    """

    leading_exponent: float = 2.0
    leading_coefficient: float | None = None
    q_sup: float = math.inf
    q_scale: float = 1.0
    # Scene family (contract item 7): its name, (required, optional) keys, a label.
    family: ClassVar[str | None] = None
    scene_keys: ClassVar[tuple[tuple[str, ...], tuple[str, ...]]] = ((), ())
    label: ClassVar[str] = ""

    # -- hooks ------------------------------------------------------------
    @abstractmethod
    def _U(self, q):
        """Potential energy (J) at overlap q (m)."""

    @abstractmethod
    def _dU(self, q):
        """Elastic force U'(q) (N)."""

    @abstractmethod
    def _d2U(self, q):
        """Tangent stiffness U''(q) (N/m)."""

    @abstractmethod
    def params(self) -> dict[str, Any]:
        """Defining parameters, for reports and scene round-trips."""

    def _inverse(self, u: np.ndarray) -> np.ndarray:
        return self._numeric_inverse(u)

    def _term_rows(self) -> list[tuple[float, ...]] | None:
        """Rows of the term table (contract item 8), or None: no table form."""
        return None

    # -- scene family (contract item 7) -------------------------------------
    @classmethod
    def from_scene(cls, read) -> Potential:
        """The potential of one scene table; ``read`` validates each value.

        ``read`` is the scene parser's reader (duck-typed): ``read.has(key)``,
        ``read.number(key)`` (a finite number > 0), ``read.text(key)`` (a bounded
        string), ``read.numbers(key)`` (a bounded table of finite numbers) and
        ``read.potentials(key)`` (an array of nested potential tables).
        """
        required, optional = cls.scene_keys
        return cls(**{k: read.number(k) for k in (*required, *optional) if read.has(k)})

    def scene_params(self) -> dict[str, Any]:
        """The family's scene table (without ``family``), accepted back by `from_scene`."""
        return self.params()

    # -- helpers for implementers ------------------------------------------
    @staticmethod
    def _ns(q):
        """Math namespace matching the kind of ``q`` (``mpmath`` or ``numpy``)."""
        return sys.modules["mpmath"] if is_mp(q) else np

    # -- public API -------------------------------------------------------
    def U(self, q):
        """Potential energy U(q) in joules.

        Parameters
        ----------
        q : float, array_like or mpmath.mpf
            Overlap (penetration) in metres, ``0 <= q <= q_sup``.

        Returns
        -------
        float, numpy.ndarray or mpmath.mpf
            U(q) in J, of the same kind as ``q``.
        """
        return self._call(self._U, q)

    def dU(self, q):
        """Elastic contact force U'(q) in newtons (same conventions as `U`)."""
        return self._call(self._dU, q)

    def d2U(self, q):
        """Tangent stiffness U''(q) in N/m (same conventions as `U`)."""
        return self._call(self._d2U, q)

    def inverse(self, u):
        """Overlap q (m) with U(q) = u, for energies u >= 0 (J); vectorised.

        Raises
        ------
        NoTurningPointError
            If some ``u`` exceeds the largest energy U reaches on its domain.
        """
        arr = np.asarray(u, dtype=float)
        if np.any(~np.isfinite(arr)) or np.any(arr < 0):
            bad = arr[~np.isfinite(arr) | (arr < 0)].flat[0]
            raise HCVInputError(f"energy must be finite and >= 0, got {bad!r}")
        out = self._inverse(np.atleast_1d(arr))
        return float(out[0]) if arr.ndim == 0 else out.reshape(arr.shape)

    def turning_point(self, E: float, *, check: bool = True) -> float:
        """Turning point q_max(E) with U(q_max) = E (assumption 4 of section 3).

        Parameters
        ----------
        E : float
            Energy in J, finite and > 0.
        check : bool
            Also check U' > 0 on (0, q_max] (assumption 3); default True.

        Returns
        -------
        float
            q_max in metres.

        Raises
        ------
        NoTurningPointError
            U does not reach E on its domain.
        NonMonotoneError
            U' <= 0 somewhere in (0, q_max].
        """
        if not (isinstance(E, (int, float, np.floating)) and math.isfinite(E) and E > 0):
            raise HCVInputError(f"energy E must be a finite number > 0, got {E!r}")
        if math.isfinite(self.q_sup):
            u_sup = self._energy_sup()
            if u_sup < E:
                raise NoTurningPointError(
                    f"U reaches only {u_sup:.6g} J at the end of its domain q = {self.q_sup:.6g} m, "
                    f"below the requested energy E = {E:.6g} J: no turning point "
                    "(lower the impact speed or stiffen the contact)"
                )
        q_max = float(self._inverse(np.array([float(E)]))[0])
        if not (math.isfinite(q_max) and q_max > 0):
            raise NoTurningPointError(
                f"no finite turning point for E = {E:.6g} J (got q_max = {q_max!r})"
            )
        if check:
            self.check_monotone(q_max)
        return q_max

    def _energy_sup(self) -> float:
        """U(q_sup) in J: the largest energy a turning point on a bounded domain can have
        (a family may keep it: it is fixed at construction)."""
        return float(self._U(np.array([self.q_sup]))[0])

    def check_monotone(self, q_max: float) -> None:
        """Check U(0) = 0 and U'(q) > 0 on a dense grid of (0, q_max].

        Raises
        ------
        HCVInputError
            U(0) is not 0 (assumption 2).
        NonMonotoneError
            U'(q) <= 0 or non-finite at some grid point (assumption 3); the
            message names the first such q.
        """
        u0 = float(self._U(np.array([0.0]))[0])
        if u0 != 0.0:
            raise HCVInputError(f"U(0) must be 0 (assumption 2 of section 3), got U(0) = {u0!r} J")
        grid = q_max * np.concatenate(
            [np.logspace(-12, 0, _MONOTONE_LOG_POINTS), np.linspace(0, 1, _MONOTONE_LIN_POINTS)[1:]]
        )
        grid = np.unique(np.clip(grid, 0.0, self.q_sup))
        grid = grid[grid > 0]
        with np.errstate(all="ignore"):
            f = self._dU(grid)
        bad = ~(np.isfinite(f) & (f > 0))
        if np.any(bad):
            qb = grid[np.argmax(bad)]
            raise NonMonotoneError(
                f"U'(q) = {f[np.argmax(bad)]:.6g} N at q = {qb:.6g} m is not > 0: the potential is "
                f"not monotone on (0, q_max = {q_max:.6g} m] (assumption 3 of section 3)"
            )

    def __add__(self, other: Potential) -> SumPotential:
        if not isinstance(other, Potential):
            return NotImplemented
        left = self.terms if isinstance(self, SumPotential) else (self,)
        right = other.terms if isinstance(other, SumPotential) else (other,)
        return SumPotential(*left, *right)

    # -- internals ----------------------------------------------------------
    def _call(self, hook, q):
        if is_mp(q):
            if not sys.modules["mpmath"].isfinite(q) or q < 0 or q > self.q_sup:
                raise DomainError(
                    f"overlap q = {q} m is outside the domain [0, {self.q_sup}] of {self!r}"
                )
            return hook(q)
        arr = np.asarray(q, dtype=float)
        bad = ~np.isfinite(arr) | (arr < 0) | (arr > self.q_sup)
        if np.any(bad):
            raise DomainError(
                f"overlap q = {arr[bad].flat[0]!r} m is outside the domain [0, {self.q_sup}] "
                f"of {self!r}"
            )
        out = hook(np.atleast_1d(arr))
        return float(out[0]) if arr.ndim == 0 else out.reshape(arr.shape)

    def _numeric_inverse(self, u: np.ndarray) -> np.ndarray:
        """Invert U by bracketing (doubling/halving) and Chandrupatla's method."""
        u = np.asarray(u, dtype=float)
        out = np.zeros_like(u)
        pos = u > 0
        if not np.any(pos):
            return out
        target = u[pos]
        # Start from the leading power law U ~ U(q_s) (q/q_s)^n, which is close for
        # small energies, so that the geometric bracket search below takes few steps.
        q_s = min(self.q_scale, self.q_sup)
        u_s = float(self._U(np.array([q_s]))[0])
        with np.errstate(all="ignore"):
            guess = q_s * (target / u_s) ** (1.0 / self.leading_exponent)
        guess = np.where(np.isfinite(guess) & (guess > 0), guess, q_s)
        hi = np.minimum(2.0 * guess, self.q_sup)
        for _ in range(_MAX_BRACKET_STEPS):
            with np.errstate(all="ignore"):
                u_hi = self._U(hi)
            if not np.all(np.isfinite(u_hi)):
                bad = np.argmax(~np.isfinite(u_hi))
                raise NoTurningPointError(
                    f"U(q) = {u_hi[bad]!r} at q = {hi[bad]:.6g} m before reaching the energy "
                    f"{target[bad]:.6g} J: no turning point (U must be finite and increasing)"
                )
            low = u_hi < target
            if not np.any(low):
                break
            at_sup = hi >= self.q_sup
            if np.any(low & at_sup):
                raise NoTurningPointError(
                    f"U reaches only {float(self._U(np.array([self.q_sup]))[0]):.6g} J at "
                    f"q_sup = {self.q_sup:.6g} m, below the energy {target[low & at_sup][0]:.6g} J:"
                    " no turning point"
                )
            with np.errstate(over="ignore"):
                hi = np.where(low, np.minimum(4 * hi, self.q_sup), hi)
        else:
            raise NoTurningPointError(
                f"U stays below the energy {target.max():.6g} J for every q up to {hi.max():.3g} m:"
                " no turning point"
            )
        lo = np.minimum(0.5 * guess, 0.5 * hi)
        for _ in range(_MAX_BRACKET_STEPS):
            high = self._U(lo) > target
            if not np.any(high):
                break
            lo = np.where(high, lo / 4, lo)
        out[pos] = _safeguarded_log_newton(self, target, lo, hi, guess)
        return out


def _safeguarded_log_newton(pot: Potential, target, lo, hi, guess):
    """Solve U(q) = target inside brackets [lo, hi] by Newton's method on log U(log q).

    Arrays ``lo`` and ``hi`` are updated in place.

    log U against log q is close to a straight line of slope n for contact
    potentials, so Newton from the power-law guess converges in a few steps; a
    step leaving the bracket is replaced by a geometric bisection. (scipy's
    elementwise Chandrupatla solver does the same job but costs ~3 ms per call in
    overhead, which made the exact solver slower than the ODE it replaces.)
    """
    log_t = np.log(target)
    q = np.clip(guess, lo, hi)
    active = np.ones(q.shape, dtype=bool)
    for _ in range(_NEWTON_MAX_ITER):
        qa, la, ha = q[active], lo[active], hi[active]
        U = pot._U(qa)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            f = np.log(U) - log_t[active]
            slope = qa * pot._dU(qa) / U
            # Multiplicative Newton step keeps the relative precision of q at any scale.
            q_new = qa * np.exp(-f / slope)
        la = np.where(f < 0, qa, la)
        ha = np.where(f > 0, qa, ha)
        bad = ~np.isfinite(q_new) | (q_new <= la) | (q_new >= ha)
        q_new = np.where(bad, np.sqrt(la * ha), q_new)
        q_new = np.where(f == 0, qa, q_new)
        converged = np.abs(q_new - qa) <= _INVERSE_XRTOL * qa
        q[active], lo[active], hi[active] = q_new, la, ha
        active[np.flatnonzero(active)[converged]] = False
        if not np.any(active):
            break
    return q


class SumPotential(Potential):
    """Sum of potentials, U = sum_i U_i (built with ``+``).

    Scene family ``sum``: ``terms`` is an array of two or more potential tables.

    Each term must satisfy the contract; the sum inherits the smallest domain
    and the smallest leading exponent (the lowest power dominates as q -> 0).
    """

    family = "sum"
    scene_keys = (("terms",), ())
    label = "sum of potentials U = U_1 + U_2 + ..."

    def __init__(self, *terms: Potential):
        if len(terms) < 2 or not all(isinstance(t, Potential) for t in terms):
            raise HCVInputError("a sum of potentials needs at least two Potential terms")
        self.terms = tuple(terms)
        self.leading_exponent = min(t.leading_exponent for t in terms)
        lead = [t.leading_coefficient for t in terms if t.leading_exponent == self.leading_exponent]
        self.leading_coefficient = None if None in lead else float(sum(lead))
        self.q_sup = min(t.q_sup for t in terms)
        self.q_scale = min(t.q_scale for t in terms)

    def _U(self, q):
        return sum(t._U(q) for t in self.terms)

    def _dU(self, q):
        return sum(t._dU(q) for t in self.terms)

    def _d2U(self, q):
        return sum(t._d2U(q) for t in self.terms)

    def _term_rows(self):
        # The terms' rows one after another; no table when some term has none.
        rows = []
        for t in self.terms:
            sub = term_rows(t)
            if sub is None:
                return None
            rows += sub
        return rows

    def params(self) -> dict[str, Any]:
        return {"terms": [dict(family=type(t).__name__, **t.params()) for t in self.terms]}

    @classmethod
    def from_scene(cls, read) -> Potential:
        return cls(*read.potentials("terms"))

    def scene_params(self) -> dict[str, Any]:
        return {
            "terms": [
                {"family": t.family or type(t).__name__, **t.scene_params()} for t in self.terms
            ]
        }

    def __repr__(self) -> str:
        return " + ".join(repr(t) for t in self.terms)
