"""Scene files: what to compute (mass, impact speeds, contact law, damping), validated.

A scene is a small TOML document::

    name = "paper-ellipsoid"
    mass = 0.05                     # kg
    velocities = [0.50, 0.99, 1.50] # m/s, impact speeds (> 0)
    kind = "impact"                 # "impact" | "two-sided" | "two-walls"
                                    # ("chain" | "lattice": assemblies, see `_assembly`)
    # gap = 0.01                    # m, two-walls only: free-flight gap between the walls
    [potential]
    family = "ellipsoid"            # power | ellipsoid | sphere | expression | sum | saturating
    a = 0.015
    b = 0.008
    c = 0.008
    Kn = 1e8
    alpha = 0.5
    [damping]                       # optional; default law = "none"
    law = "universal"               # a registered law (reference_impl.theory.laws.LAWS;
                                    # hcv scenes --laws lists them)
    zeta = 0.2                      # or restitution = 0.8 (+ restitution_end), or C0 with K and M

Every problem raises `SceneError` (or, for a potential that breaks the
paper's assumptions, the `HCVInputError` subclass the potential raised) with
one line naming the scene and the offending key.
"""

from __future__ import annotations

import json
import os
import tomllib
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

from reference_impl.errors import HCVInputError, SceneError
from reference_impl.potentials import FAMILIES, Potential
from reference_impl.scenes._assembly import ASSEMBLY_KINDS, AssemblyFields, assembly_fields
from reference_impl.scenes._catalogue import embedded_scenes
from reference_impl.scenes._damping import _ENDS, _damping, _solve_strength, _universal_zeta
from reference_impl.scenes._fields import (
    _keys,
    _number,
    _short,
    _string,
    _table,
    _Where,
)
from reference_impl.scenes._law_restitution import strength_text
from reference_impl.theory.laws import DampingLaw

__all__ = [
    "AssemblyScene",
    "Scene",
    "load_scene",
    "parse_scene",
    "scene_from_dict",
    "embedded_scenes",
    "scene_show",
    "scene_toml",
]

# A scene is a few lines; refusing anything larger keeps a wrong path (a log,
# a binary) from being read whole into memory.
_MAX_SCENE_BYTES = 1_000_000
# Upper bounds of the sizes a scene controls, checked before any work: every
# speed is a full solve (and a critical-step search under dt-crit and bench);
# an expression is parsed symbolically and differentiated twice; a sum is built
# term by term (and nested sums recursively).
_MAX_SPEEDS = 256
_MAX_EXPRESSION_CHARS = 2000
_MAX_PARAMS = 64
_MAX_TERMS = 64
_MAX_DEPTH = 8
_KINDS = ("impact", "two-sided", "two-walls")
# Assembly kinds (chains and lattices, `reference_impl.scenes._assembly`): listed in the
# message of an unknown kind, parsed by `_assembly_scene`.
_ALL_KINDS = _KINDS + ASSEMBLY_KINDS
_TOP_KEYS = ("name", "mass", "velocities", "kind", "gap", "potential", "damping")


@dataclass(frozen=True)
class Scene:
    """One validated scene.

    Attributes
    ----------
    name : str
        Scene name (the file stem when the file gives none).
    mass : float
        Particle mass m in kg (> 0).
    velocities : tuple of float
        Impact speeds v0 in m/s (> 0); each has a turning point.
    kind : str
        ``"impact"`` (one contact), ``"two-sided"`` (U(|q|), an oscillator
        through q = 0) or ``"two-walls"`` (bouncing between two walls).
    gap : float or None
        Free-flight gap between the walls in m (``"two-walls"`` only).
    potential : Potential
        The contact potential U(q).
    damping_law : str
        ``"none"``, ``"universal"`` (Theorem 3) or another registered law
        (`reference_impl.theory.laws.LAWS`).
    zeta : float or None
        Damping ratio zeta = C0 / (2 sqrt(K M)) of the universal law; None
        for every other law (use `law`).
    law : DampingLaw
        The damping law with its parameters (SI units), whatever its name.
    source : str
        Where the scene came from (a path, ``<embedded>/name.toml`` or the
        label given to `parse_scene`).
    restitution_end : str
        Where the scene's restitution is read: ``"overlap"`` (q back to 0) or
        ``"zero-force"`` (``damping.restitution_end``); what ``hcv bench``'s delivery
        metric compares with the asked restitution.
    calibration : dict or None
        For a law other than 'universal' given by ``restitution`` at
        ``restitution_speed``: the request and the strength solved for it
        (``parameter``, ``value``; a polynomial's ``scale`` too). `law` holds the
        solved value.
    """

    name: str
    mass: float
    velocities: tuple[float, ...]
    kind: str
    gap: float | None
    potential: Potential
    damping_law: str
    zeta: float | None
    source: str
    law: DampingLaw | None = None
    restitution_end: str = "overlap"
    calibration: dict | None = None

    def __post_init__(self):
        if self.law is None:  # built positionally by older callers: derive it
            if self.damping_law == "universal":
                law = DampingLaw("universal", {"zeta": float(self.zeta or 0.0)})
            else:
                law = DampingLaw("none")
            object.__setattr__(self, "law", law)

    @property
    def equivalent_universal_zeta(self) -> float | None:
        """The damping ratio of the universal law (Theorem 3) with the same C(q) as this
        scene's law, or None when no universal law has it.

        0 for no damping or a law at strength 0 (e.g. solved for ``restitution = 1``);
        on a Hooke potential (``family = "power"``, ``p = 1``) a constant C = c (``linear``;
        ``power`` with exponent 0; ``polynomial`` [c0]; ``viscoelastic`` A k) is the
        universal law at zeta = c / (2 sqrt(m k)). A code that integrates only the universal
        law runs such a scene exactly at this zeta.
        """
        return _universal_zeta(self.potential, self.mass, self.law)

    def to_dict(self) -> dict[str, Any]:
        """The scene in the schema of the TOML file, plus ``source`` (JSON-safe).

        Without ``source`` (and ``calibration``, present when a law's strength was
        solved from a restitution) the dict is accepted back by `scene_from_dict`.
        """
        out: dict[str, Any] = {
            "name": self.name,
            "mass": self.mass,
            "velocities": list(self.velocities),
            "kind": self.kind,
        }
        if self.gap is not None:
            out["gap"] = self.gap
        out["potential"] = potential_to_dict(self.potential)
        out["damping"] = self.law.to_dict()
        out["source"] = self.source
        if self.calibration is not None:
            # how the law's strength was found (not read back: the law's value decides)
            out["calibration"] = dict(self.calibration)
        return out


@dataclass(frozen=True)
class AssemblyScene(Scene):
    """A chain or lattice scene (``kind = "chain"`` or ``"lattice"``): a `Scene` whose
    ``mass`` and ``velocities`` are the striker's (body 0) and whose ``assembly`` holds the
    rest (`reference_impl.scenes._assembly.AssemblyFields`); ``gap`` is every contact's
    gap at the start (m). ``reference_impl.scenes._assembly.assembly_model`` builds what
    the kernel runs."""

    assembly: AssemblyFields | None = None

    def to_dict(self) -> dict[str, Any]:
        """The scene in the schema of the TOML file, plus ``source`` (JSON-safe)."""
        out: dict[str, Any] = {"name": self.name, "kind": self.kind}
        out.update(self.assembly.to_dict(self.kind, float(self.gap or 0.0)))
        out.setdefault("velocities", self.velocities[0])
        out["potential"] = potential_to_dict(self.potential)
        out["damping"] = self.law.to_dict()
        out["source"] = self.source
        return out


def _assembly_scene(err: _Where, data: dict, source: str, potentials: dict | None) -> Scene:
    """The `AssemblyScene` of a chain or lattice table (see `reference_impl.scenes._assembly`)."""
    kind = data["kind"]
    name = _string(err, data.get("name", Path(source).stem or "scene"), "name")
    fields, potential, mass, v0, gap = assembly_fields(
        err, data, kind, lambda table: _cached_potential(err, table, potentials)[0]
    )
    law, zeta, dlaw, _ = _damping(err, data.get("damping", {}))
    if law not in ("none", "universal"):
        raise err(f"damping.law = {law!r}: an assembly runs 'none' or 'universal' only")
    # every contact of the assembly must have a turning point at the whole initial
    # kinetic energy (the largest load one contact can take)
    vs = fields.body_velocities or (v0,)
    ms = (fields.masses * len(vs))[: len(vs)] if fields.body_velocities else (mass,)
    energy = 0.5 * sum(m * v * v for m, v in zip(ms, vs, strict=False))
    try:
        potential.turning_point(energy)
    except HCVInputError as exc:
        raise _with_context(exc, f"scene {source}: initial energy E = {energy:.6g} J") from exc
    return AssemblyScene(
        name, mass, (v0,), kind, gap, potential, law, zeta, source, dlaw, "overlap", None, fields
    )


def potential_to_dict(pot: Potential) -> dict[str, Any]:
    """A potential as a ``[potential]`` table of the scene schema (its family's own)."""
    return {"family": pot.family or type(pot).__name__, **pot.scene_params()}


class _Reader:
    """What a family's ``from_scene`` reads its table with: each value checked, bounded,
    and named by its scene path in the one-line error."""

    def __init__(self, err: _Where, table: dict, path: str, depth: int):
        self._err, self._table, self._path, self._depth = err, table, path, depth

    def has(self, key: str) -> bool:
        return key in self._table

    def number(self, key: str) -> float:
        return _number(self._err, self._table[key], f"{self._path}.{key}", low=0.0)

    def text(self, key: str) -> str:
        return _string(
            self._err, self._table[key], f"{self._path}.{key}", max_chars=_MAX_EXPRESSION_CHARS
        )

    def numbers(self, key: str) -> dict[str, float]:
        name = f"{self._path}.{key}"
        table = _table(self._err, self._table[key], name)
        if len(table) > _MAX_PARAMS:
            raise self._err(f"{name} has {len(table)} entries; at most {_MAX_PARAMS}")
        return {k: _number(self._err, v, f"{name}.{k}") for k, v in table.items()}

    def potentials(self, key: str) -> list[Potential]:
        name = f"{self._path}.{key}"
        items = self._table[key]
        if not isinstance(items, list) or not 2 <= len(items) <= _MAX_TERMS:
            raise self._err(
                f"{name} must be an array of at least two (at most {_MAX_TERMS}) potential tables"
            )
        return [
            _potential(self._err, item, f"{name}[{i}]", self._depth + 1)
            for i, item in enumerate(items)
        ]


def _potential(err: _Where, table, path: str, depth: int = 0) -> Potential:
    """Build the potential of one ``[potential]`` (or ``[[potential.terms]]``) table.

    The family's class (`reference_impl.potentials.FAMILIES`) names its keys and reads
    its own table (`Potential.from_scene`); nothing here knows a family by name.
    """
    if depth > _MAX_DEPTH:
        raise err(f"{path}: sums nested more than {_MAX_DEPTH} deep")
    table = _table(err, table, path)
    if "family" not in table:
        raise err(f"missing key '{path}.family' (one of {', '.join(FAMILIES)})")
    family = _string(err, table["family"], f"{path}.family", tuple(FAMILIES))
    cls = FAMILIES[family]
    required, optional = cls.scene_keys
    _keys(err, table, f"{path}.", ("family", *required, *optional), required)
    return _construct(err, path, cls.from_scene, _Reader(err, table, path, depth))


def _construct(err: _Where, path: str, cls, *args, **kwargs) -> Potential:
    """cls(*args, **kwargs); a potential's own error keeps its type, gains the scene name."""
    try:
        return cls(*args, **kwargs)
    except SceneError:
        raise
    except HCVInputError as exc:
        raise _with_context(exc, f"scene {err.source}: {path}") from exc


# Stands for the scene's source in a cached potential error (replaced by each scene's own).
_SOURCE_MARK = "\x00scene-source\x00"


def _cached_potential(err: _Where, table, cache: dict | None) -> tuple[Potential, str | None]:
    """`_potential` of the scene's table and its cache key (None: not cached)."""
    if cache is None:
        return _potential(err, table, "potential"), None
    try:
        key = json.dumps(table, sort_keys=True, default=repr)
    except (TypeError, ValueError, RecursionError):  # not plain data: no caching
        return _potential(err, table, "potential"), None
    if key not in cache:
        try:
            cache[key] = _potential(_Where(_SOURCE_MARK), table, "potential")
        except HCVInputError as exc:
            cache[key] = exc
    hit = cache[key]
    if isinstance(hit, HCVInputError):
        raise type(hit)(str(hit).replace(_SOURCE_MARK, err.source))
    return hit, key


def _with_context(exc: HCVInputError, prefix: str) -> HCVInputError:
    """The same error type with the scene context in front of its message."""
    return type(exc)(f"{prefix}: {exc}")


def scene_from_dict(
    data: dict[str, Any], source: str = "<dict>", *, potentials: dict | None = None
) -> Scene:
    """Validate a parsed scene document and build the `Scene`.

    Parameters
    ----------
    data : dict
        The TOML document as a dict (see the module docstring for the keys).
    source : str
        Label used in error messages and stored as ``Scene.source``.
    potentials : dict, optional
        A cache shared by many scenes (a sweep's cases): each distinct
        ``[potential]`` table is validated once (an expression's exact sympy
        checks cost ~25 ms) and its potential, or its error, reused.

    Raises
    ------
    SceneError
        Missing, unknown or invalid keys and values.
    HCVInputError
        Its subclass raised by the potential (`ExpressionError`,
        `NonMonotoneError`, `NoTurningPointError`, ...), with the scene named.
    """
    err = _Where(source)
    data = _table(err, data, "the scene")
    if data.get("kind") in ASSEMBLY_KINDS:
        return _assembly_scene(err, data, source, potentials)
    _keys(err, data, "", _TOP_KEYS, ("mass", "velocities", "potential"))
    name = _string(err, data.get("name", Path(source).stem or "scene"), "name")
    mass = _number(err, data["mass"], "mass", low=0.0)
    vels = data["velocities"]
    if not isinstance(vels, list) or not vels:
        raise err(f"velocities must be a non-empty array of speeds in m/s, got {_short(vels)}")
    if len(vels) > _MAX_SPEEDS:
        raise err(f"velocities has {len(vels)} speeds; at most {_MAX_SPEEDS}")
    velocities = tuple(_number(err, v, f"velocities[{i}]", low=0.0) for i, v in enumerate(vels))
    kind = _string(err, data.get("kind", "impact"), "kind", _ALL_KINDS)
    gap = None
    if kind == "two-walls":
        if "gap" not in data:
            raise err("kind = 'two-walls' needs gap, the free-flight gap between the walls in m")
        gap = _number(err, data["gap"], "gap", low=0.0)
    elif "gap" in data:
        raise err(f"gap applies to kind = 'two-walls' only, but kind = {kind!r}; remove it")
    law, zeta, dlaw, request = _damping(err, data.get("damping", {}))
    potential, key = _cached_potential(err, data["potential"], potentials)
    if dlaw.A and float(potential.leading_exponent) < 2.0:
        # checked here, not first at solve time, so the message names the scene file
        raise err(
            f"damping law {dlaw.name!r} needs U'' finite at contact (leading exponent "
            "n >= 2, force exponent p >= 1); got n = "
            f"{float(potential.leading_exponent):.6g}, where C = A U'' is infinite at q = 0"
        )
    # A potential with a turning point at energy E has one at every lower energy (U rises
    # continuously from 0): with a cache, energies up to the largest one checked are known.
    checked = potentials.get(("energy", key), 0.0) if key is not None else 0.0
    for v in velocities:
        energy = 0.5 * mass * v * v
        if energy <= checked:
            continue
        try:
            potential.turning_point(energy)
        except HCVInputError as exc:
            prefix = f"scene {source}: velocity {v:g} m/s (E = {energy:.6g} J)"
            raise _with_context(exc, prefix) from exc
        if key is not None:
            checked = potentials[("energy", key)] = energy
    end = _string(
        err,
        data.get("damping", {}).get("restitution_end", "overlap"),
        "damping.restitution_end",
        _ENDS,
    )
    calibration = None
    if request is not None:
        dlaw, calibration = _solve_strength(err, potential, mass, dlaw, request)
    return Scene(
        name, mass, velocities, kind, gap, potential, law, zeta, source, dlaw, end, calibration
    )


def parse_scene(text: str, source: str = "<string>") -> Scene:
    """Parse and validate the TOML text of a scene.

    Parameters
    ----------
    text : str
        TOML document.
    source : str
        Label for messages and ``Scene.source`` (e.g. the file path).
    """
    if not isinstance(text, str):
        kind = type(text).__name__
        raise SceneError(f"scene {source}: the scene text must be a string, got {kind}")
    if len(text) > _MAX_SCENE_BYTES:
        raise SceneError(
            f"scene {source}: {len(text)} characters is too large for a scene "
            f"(limit {_MAX_SCENE_BYTES})"
        )
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"scene {source}: TOML syntax error: {exc}") from None
    except RecursionError:  # arrays or tables nested thousands deep
        raise SceneError(f"scene {source}: nested too deeply to be a scene") from None
    return scene_from_dict(data, source)


def load_scene(path_or_name: str | os.PathLike) -> Scene:
    """Load a scene from a ``.toml`` file, or the embedded scene of that name.

    Parameters
    ----------
    path_or_name : str or os.PathLike
        A path (anything that is a path object, ends in ``.toml`` or contains a
        directory separator, or names an existing file), else the name of an
        embedded scene (see `embedded_scenes`).
    """
    if not isinstance(path_or_name, (str, os.PathLike)):
        raise SceneError(f"scene {path_or_name!r}: give a file path or an embedded scene name")
    text_arg = os.fspath(path_or_name)
    looks_like_path = (
        isinstance(path_or_name, os.PathLike)
        or text_arg.endswith(".toml")
        or os.sep in text_arg
        or "/" in text_arg
        or Path(text_arg).is_file()
    )
    if not looks_like_path:
        names = embedded_scenes()
        if text_arg not in names:
            raise SceneError(
                f"scene {text_arg!r}: no such file and no embedded scene of that name "
                f"(embedded: {', '.join(names)})"
            )
        res = resources.files(__package__) / f"{text_arg}.toml"
        return parse_scene(res.read_text(encoding="utf-8"), f"<embedded>/{text_arg}.toml")
    path = Path(text_arg)
    if not path.exists():
        raise SceneError(
            f"scene file {text_arg}: not found; give an existing .toml file or an "
            "embedded scene name"
        )
    if not path.is_file():
        raise SceneError(f"scene file {text_arg}: is not a regular file")
    try:
        size = path.stat().st_size
        if size > _MAX_SCENE_BYTES:
            raise SceneError(
                f"scene file {text_arg}: {size} bytes is too large for a scene "
                f"(limit {_MAX_SCENE_BYTES}); is this the right file?"
            )
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise SceneError(
            f"scene file {text_arg}: not UTF-8 text ({exc.reason} at byte {exc.start})"
        ) from None
    except OSError as exc:
        raise SceneError(f"scene file {text_arg}: cannot be read ({exc.strerror})") from None
    return parse_scene(text, text_arg)


def scene_toml(path_or_name: str | os.PathLike) -> str:
    """The TOML text of a catalogue scene (with its comments), or of a scene file.

    The scene is loaded first (`load_scene`), so an unknown name or an invalid file
    raises `SceneError` with one line.
    """
    load_scene(path_or_name)
    return _toml_text(path_or_name)


def scene_show(path_or_name: str | os.PathLike) -> str:
    """What ``hcv scenes --show`` prints: the scene's TOML (`scene_toml`) and, for a law
    whose strength was solved from ``restitution`` at ``restitution_speed``, a last
    comment line ``# solved: alpha = ... s/m (e = ... at ... m/s, ... end)`` (still
    valid TOML: the output loads back as the same scene).
    """
    scene = load_scene(path_or_name)
    text = _toml_text(path_or_name)
    if scene.calibration is None:
        return text
    sep = "" if text.endswith("\n") or not text else "\n"
    return f"{text}{sep}# solved: {strength_text(scene.law, scene.calibration)}\n"


def _toml_text(path_or_name: str | os.PathLike) -> str:
    """The file's (or the catalogue scene's) text, as it is (loaded already)."""
    text_arg = os.fspath(path_or_name)
    if text_arg in embedded_scenes() and not Path(text_arg).is_file():
        return (resources.files(__package__) / f"{text_arg}.toml").read_text(encoding="utf-8")
    return Path(text_arg).read_text(encoding="utf-8")
