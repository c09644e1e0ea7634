"""What an adapter declares for the bench (contract items 12 and 13): its time-stepping
scheme and the order it claims (`Scheme`, read by `scheme_of`), and, for a built-in code,
how the code takes a restitution, which variants the report shows, its install extra
and pytest marker (`CodeInfo`).

The bench judges a code's implementation against the error its *declared* scheme makes
on the declared law (`reference_impl.bench.scorecard._schemes` runs that scheme on the exact law),
so a first-order implicit code is not held to velocity Verlet's error (issue 40, §1).
The registry (`reference_impl.adapters.registry.builtin_codes`) makes every list of
codes (the report's side-by-side variants, the install lines, the markers) from the
`CodeInfo` of the registered built-in adapters.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import SimpleNamespace

from reference_impl.errors import HCVInputError

__all__ = [
    "ASSEMBLY_KINDS",
    "SCHEMES",
    "CodeInfo",
    "Scheme",
    "declared_assembly",
    "declared_scheme",
    "offset_refusal",
    "scheme_of",
]

# Characters of a refused value shown in its one-line error: a hostile declaration (a
# 4000-character scheme name in a cmd[...] spec) is named, not echoed whole.
_SHOWN = 60


def _shown(value) -> str:
    """``repr(value)``, cut to `_SHOWN` characters (the error line stays one short line)."""
    text = repr(value)
    return text if len(text) <= _SHOWN else text[: _SHOWN - 3] + "..."


def _number(value) -> bool:
    """A real number, never a boolean (``claimed_order=true`` is no order of 1)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool)


# name -> (nominal order, one line). The nominal order is the scheme's order on a smooth
# force; on a contact with a dashpot evaluated explicitly, velocity Verlet is first
# order (the bench measures the scheme's own order on each scene). None: a
# variable-step, error-controlled code, whose dt is its sampling, not its step.
SCHEMES: dict[str, tuple[float | None, str]] = {
    "velocity-verlet": (2.0, "velocity (explicit) Verlet, kick-drift-kick"),
    "symplectic-euler": (1.0, "symplectic (semi-implicit) Euler: v then q"),
    "explicit-euler": (1.0, "explicit (forward) Euler"),
    "implicit-euler": (1.0, "implicit (backward) Euler, q and v at the new step"),
    "rk4": (4.0, "classical fourth-order Runge-Kutta (a higher-order method)"),
    "variable-step": (None, "variable-step, error-controlled (dt is its sampling)"),
}


@dataclass(frozen=True)
class Scheme:
    """A declared time-stepping scheme.

    Parameters
    ----------
    name : str
        A key of `SCHEMES`.
    order : float or None
        The order the code claims (> 0); None for a variable-step scheme.
    rtol : float or None
        A variable-step scheme's relative error tolerance (dimensionless, in (0, 1));
        None for a fixed-step scheme.
    """

    name: str
    order: float | None
    rtol: float | None = None

    @property
    def variable(self) -> bool:
        """The code chooses its own steps: ``dt`` is only its sampling."""
        return self.name == "variable-step"

    @property
    def description(self) -> str:
        text = SCHEMES[self.name][1]
        if self.variable:
            return f"{text}, rtol {self.rtol:g}"
        return f"{text}, order {self.order:g}"

    def to_json(self) -> dict:
        return {"name": self.name, "order": self.order, "rtol": self.rtol}


def scheme_of(adapter) -> Scheme:
    """The scheme an adapter (or variant) declares, checked (contract item 12).

    Reads ``time_scheme`` (a key of `SCHEMES`; default velocity Verlet), ``claimed_order``
    (default: the scheme's nominal order) and, for ``variable-step``, ``scheme_rtol``.

    Raises
    ------
    HCVInputError
        An unknown scheme, an order that is not a positive number, or a variable-step
        scheme without its tolerance (one line naming the value).
    """
    name = getattr(adapter, "time_scheme", "velocity-verlet")
    label = getattr(adapter, "label", type(adapter).__name__)
    if not isinstance(name, str) or name not in SCHEMES:
        raise HCVInputError(
            f"adapter {_shown(label)}: time_scheme {_shown(name)} is not one of {', '.join(SCHEMES)}"
        )
    nominal = SCHEMES[name][0]
    if nominal is None:
        rtol = getattr(adapter, "scheme_rtol", None)
        if not (_number(rtol) and 0.0 < rtol < 1.0):
            raise HCVInputError(
                f"adapter {_shown(label)}: a variable-step scheme declares scheme_rtol in (0, 1), "
                f"got {_shown(rtol)}"
            )
        return Scheme(name, None, float(rtol))
    order = getattr(adapter, "claimed_order", None)
    if order is None:
        order = nominal
    if not (_number(order) and math.isfinite(order) and order > 0):
        raise HCVInputError(
            f"adapter {_shown(label)}: claimed_order must be a positive number, got {_shown(order)}"
        )
    return Scheme(name, float(order))


def declared_scheme(label: str, time_scheme=None, claimed_order=None, scheme_rtol=None):
    """The scheme a ``cmd:`` program declares in its ``cmd[...]`` arguments, checked.

    The same declaration as a Python adapter's attributes (contract item 12), given as
    ``cmd[time_scheme=implicit-euler,claimed_order=1]:COMMAND`` (as ``sustained=true``
    declares two-walls scenes): read before anything runs, so a bad one stops the bench
    with exit status 2 and nothing executed. Stricter than `scheme_of` on what the
    scheme does not use: an order given to a variable-step scheme or a tolerance to a
    fixed-step one is refused (a typo of the scheme would otherwise drop it silently).

    Parameters
    ----------
    label : str
        The adapter's label, for the error line.
    time_scheme : str or None
        A key of `SCHEMES`; None: nothing declared (velocity Verlet, as before).
    claimed_order : float or None
        The order claimed (> 0, finite; default the scheme's nominal order).
    scheme_rtol : float or None
        A variable-step scheme's relative tolerance (dimensionless, in (0, 1)).

    Returns
    -------
    Scheme or None
        None when none of the three is given.

    Raises
    ------
    HCVInputError
        One line naming the offending value.
    """
    if time_scheme is None and claimed_order is None and scheme_rtol is None:
        return None
    if time_scheme is None:
        raise HCVInputError(
            f"adapter {_shown(label)}: claimed_order and scheme_rtol need time_scheme (one of "
            f"{', '.join(SCHEMES)})"
        )
    scheme = scheme_of(
        SimpleNamespace(label=label, time_scheme=time_scheme, claimed_order=claimed_order,
                        scheme_rtol=scheme_rtol)
    )  # fmt: skip
    if scheme.variable and claimed_order is not None:
        raise HCVInputError(
            f"adapter {_shown(label)}: a variable-step scheme claims no order (its dt is its "
            f"sampling), got claimed_order={_shown(claimed_order)}"
        )
    if not scheme.variable and scheme_rtol is not None:
        raise HCVInputError(
            f"adapter {_shown(label)}: scheme_rtol is a variable-step scheme's tolerance, got "
            f"scheme_rtol={_shown(scheme_rtol)} with time_scheme {scheme.name!r}"
        )
    return scheme


# The assembly scenes a ``cmd:`` program may declare (contract item 14): chains of spheres
# on a line and periodic lattices, as the built-in codes run them.
ASSEMBLY_KINDS = ("chain", "lattice")


def declared_assembly(label: str, assembly=None, advice=None) -> tuple[frozenset, bool]:
    """The assembly scenes a ``cmd:`` program declares, ``cmd[assembly=chain+lattice]``.

    The ``cmd:`` form of contract item 14's ``supports_assembly`` / ``supports_lattice``
    (and of ``step_advice``, ``advice=true``), read before anything runs as the scheme
    is (`declared_scheme`): a program without it is never sent an assembly request and
    declines assembly scenes in one line, as before.

    Parameters
    ----------
    label : str
        The adapter's label, for the error line.
    assembly : str or None
        ``"chain"``, ``"lattice"`` or both joined by ``+`` (``"chain+lattice"``; a comma
        would end the argument in ``cmd[...]``); None: no assembly scenes.
    advice : bool or None
        The program answers ``"advice"`` requests with its own step advice (needs
        ``assembly``); None or False: it gives none.

    Returns
    -------
    (frozenset of str, bool)
        The kinds declared (a subset of `ASSEMBLY_KINDS`) and whether advice is.

    Raises
    ------
    HCVInputError
        One line naming the offending value (an unknown or repeated kind, an advice
        that is not true/false, or advice without assembly).
    """
    if advice is not None and not isinstance(advice, bool):
        raise HCVInputError(
            f"adapter {_shown(label)}: advice must be true or false, got {_shown(advice)}"
        )
    if assembly is None:
        if advice:
            raise HCVInputError(
                f"adapter {_shown(label)}: advice=true needs assembly= (the scenes advised: "
                f"{' or '.join(ASSEMBLY_KINDS)}, joined by '+')"
            )
        return frozenset(), False
    parts = assembly.split("+") if isinstance(assembly, str) else None
    if not parts or any(p not in ASSEMBLY_KINDS for p in parts) or len(set(parts)) != len(parts):
        raise HCVInputError(
            f"adapter {_shown(label)}: assembly={_shown(assembly)} is not one of "
            f"{', '.join(ASSEMBLY_KINDS)} or both joined by '+' (assembly=chain+lattice)"
        )
    return frozenset(parts), bool(advice)


def offset_refusal(adapter) -> str | None:
    """Why a code that declares a force offset cannot be scored, else None.

    A code whose contact force starts before the bodies overlap (``force_offset`` > 0,
    in m: PyBullet's contactSlop, a skin) integrates U(q + offset), which no law of the
    suite describes (every U starts at q = 0): its scenes are skipped with this reason,
    naming the offset, rather than scored against a law it does not integrate.
    """
    offset = getattr(adapter, "force_offset", 0.0)
    if offset in (0, 0.0, None):
        return None
    return (
        f"declares a force offset of {offset!r} m (the force starts at q = -offset), which "
        "no contact law of the suite describes (U(q) starts at q = 0): set it to 0 to be scored"
    )


@dataclass(frozen=True)
class CodeInfo:
    """What the registry, the report and CI need to know of a built-in code (item 13).

    Parameters
    ----------
    code : str
        The code's name as the report prints it ("LAMMPS").
    restitution_input : str
        How the code takes a restitution, in the words of its own documentation (the
        input the user types, e.g. "pair_style granular ... damping tsuji: e").
    report_variants : tuple of (str, float)
        (adapter spec, exponent p of the scene's power law: 1.5 Hertz, 1 Hooke) of the
        variants the report's "codes side by side" section runs.
    calibrated : tuple of (str, float, str)
        (adapter spec, p, option searched) of the variants ``hcv calibrate`` is shown for.
    extra : str or None
        The pip extra of pyproject.toml that installs the code (None: not from pip).
    apt : str or None
        The Debian package that installs it (None: not from apt).
    marker : str
        The pytest marker of its tests (declared in pyproject.toml).
    test_module : str
        Its test module, relative to the repository root.
    """

    code: str
    restitution_input: str
    report_variants: tuple = ()
    calibrated: tuple = ()
    extra: str | None = None
    apt: str | None = None
    marker: str = ""
    test_module: str = ""

    @classmethod
    def pip(cls, name: str, **kw) -> CodeInfo:
        """A code installed by the pip extra ``name``, whose tests are marked ``name`` in
        ``verification/test_<name>.py`` (the convention of the codes from pip).

        Parameters
        ----------
        name : str
            The adapter's registry name (``"drake"``).
        **kw
            ``code``, ``restitution_input``, ``report_variants``, ``calibrated``.
        """
        return cls(extra=name, marker=name, test_module=f"verification/test_{name}.py", **kw)
