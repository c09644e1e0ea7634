"""The codes side by side: asked restitution -> delivered restitution (issue 28).

For every built-in code (LAMMPS, LIGGGHTS, Kratos DEM, YADE, MuJoCo) and the
variants users run, the impact of issue 28's sphere (m = 4.1103 g; Hertz
k = 1.0879e10 N/m^1.5 or, for the linear codes, Hooke k = 1e6 N/m) on a wall is
run with each asked restitution, at 20 and 200 steps per contact and at two
speeds four decades apart. Each row keeps the delivered restitution (q = 0 end),
the tensile force at the end of contact (max pull / peak push) and the exact
restitution of the law the code declares.

Each asked e is typed into the code's own e input as is, as a user does: LAMMPS
coeff_restitution / tsuji, LIGGGHTS ``coefficientRestitution``, Kratos
``COEFFICIENT_OF_RESTITUTION`` and YADE ``en`` (and, for ViscElMat, the tc = sqrt((pi^2
+ ln^2 e) m / k) and cn = 2 (2 zeta sqrt(m k)) of Pournin's linear law of that e at
q = 0) by their adapters themselves (the mapping ``hcv bench`` runs, so the gate and
this table answer one question); MuJoCo's ``dampratio`` = that zeta by `typed_spec`
(its adapter still types the input that delivers the asked e at the end MuJoCo
delivers it, which would hide what the code does with e typed in, the table's point);
an option given in the spec is kept. Codes that are not installed give one
row saying so. Runs go through the benchmark's executors (a worker process per
isolated adapter, its timeout), so a crashing code fails its rows only.

This lives in the bench layer, not in `reference_impl.studies`, because it runs
adapters (the layering test keeps studies below adapters).

Rendering (for the report section): one table per speed pair, rows = code /
variant, columns = asked e; each cell "e(200) / e(20)" at the lower speed, with a
mark where the two speeds differ by more than the step error (1e-3), the tensile
column as a percentage of the peak force, and the declared law's exact e in a
tooltip or footnote. A delivered e further from the asked one than 1 % in bold.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

from reference_impl.adapters.base import AdapterScene
from reference_impl.adapters.registry import builtin_codes, parse_spec
from reference_impl.bench.calibration.calibrate import calibrate
from reference_impl.bench.measure import exact_reference, measure
from reference_impl.bench.worker import make_executor
from reference_impl.errors import HCVInputError
from reference_impl.exact.solve import solve_impact
from reference_impl.potentials.power import PowerLaw
from reference_impl.scenes import scene_from_dict
from reference_impl.theory.damping import zeta_from_restitution

__all__ = [
    "ASKED",
    "CALIBRATED",
    "CODES",
    "CodeRow",
    "calibration_table",
    "codes_table",
    "typed_spec",
]

MASS = 4.1103e-3  # kg: 10 mm steel sphere
HERTZ_K = 1.0879e10  # N/m^1.5: on a steel wall (E* = 115.4 GPa, R = 5 mm)
HOOKE_K = 1.0e6  # N/m: the bench's linear scene
ASKED = (0.9, 0.5, 0.2)
STEPS_PER_CONTACT = (200, 20)
SPEEDS = (0.01, 100.0)  # m/s, four decades apart
_TIMEOUT = 120.0  # s per run
# (code, adapter spec, p): the variants users run, on a wall, and (code, adapter spec with
# its keys, p, option searched): the input that delivers e. Both from the registry: each
# built-in adapter declares them (`CodeInfo.report_variants`, `CodeInfo.calibrated`).
CODES = tuple(
    (info.code, spec, p) for info in builtin_codes().values() for spec, p in info.report_variants
)
CALIBRATED = tuple(
    (info.code, spec, p, option)
    for info in builtin_codes().values()
    for spec, p, option in info.calibrated
)


@dataclass
class CodeRow:
    """One run of the table (``error`` set, numbers NaN, when it did not deliver)."""

    code: str
    variant: str
    k: float
    p: float
    asked: float
    steps_per_contact: int
    v0: float
    delivered: float = math.nan
    tensile: float = math.nan
    declared_exact: float = math.nan
    error: str = ""

    def to_dict(self) -> dict:
        return asdict(self)


def _typed_options(spec: str, e: float, p: float) -> dict:
    """The options of ``spec`` that type ``e`` into the code's own input as is.

    Empty for an adapter or a variant with no such input (the reference adapter, a
    ``cmd:`` program, LAMMPS's constant dampings: their own mapping stands), and for an
    input the spec already sets.
    """
    try:
        name, opts = parse_spec(spec)
    except HCVInputError:
        return {}  # make_executor says why, in the rows
    bare = set(map(str, opts.pop("__bare__", [])))

    def pick(key: str, allowed: tuple) -> str | None:  # keyed (mode=sap) or bare (sap)
        return opts.get(key) or next((b for b in bare if b in allowed), None)

    k = HERTZ_K if p == 1.5 else HOOKE_K
    zeta = float(zeta_from_restitution(e)) if e < 1.0 else 0.0  # linear law's e at q = 0
    typed: dict = {}
    # LAMMPS (tsuji, coeff_restitution), LIGGGHTS, Kratos (COEFFICIENT_OF_RESTITUTION) and
    # YADE (en; ViscElMat's tc / en and kn / cn of e) type the asked e as is themselves
    # (their adapters' mapping, the one the gate runs: issue 40, §2)
    if name == "mujoco" and "damping" not in opts:
        typed = {"dampratio": zeta}
    elif name == "drake" and pick("mode", ("sap",)) == "sap":
        # SAP's dashpot c = 2 zeta sqrt(m k), typed as its relaxation time tau = c / k
        typed = {"relaxation_time": 2.0 * zeta * math.sqrt(MASS / k)}
    elif name == "pybullet" and pick("mode", ("soft",)) == "soft" and "damping" not in opts:
        typed = {"damping": 2.0 * zeta * math.sqrt(MASS * k)}  # contactDamping, a dashpot
    return {key: float(v) for key, v in typed.items() if key not in opts}


def typed_spec(spec: str, e: float, p: float, keep: str | None = None) -> tuple[str, str]:
    """``spec`` with the code's own e input set to ``e`` as a user types it.

    Parameters
    ----------
    spec : str
        An adapter spec of `CODES` (or any other: those without an e input come back
        unchanged).
    e : float
        The asked restitution, typed as is.
    p : float
        Exponent of the scene's power law (1.5 Hertz, 1 Hooke): YADE ViscElMat's tc and
        cn need its k.
    keep : str, optional
        An option left out (the one `calibration_table` searches).

    Returns
    -------
    (str, str)
        The spec to run and the options added (``,key=value`` as adapters' labels
        write them, removed from the row's variant name).
    """
    typed = {k: v for k, v in _typed_options(spec, e, p).items() if k != keep}
    if not typed:
        return spec, ""
    added = "".join(f",{key}={v!r}" for key, v in typed.items())
    spec = spec.strip()
    if spec.endswith("]"):
        return f"{spec[:-1]}{added}]", added
    return f"{spec}[{added[1:]}]", added


def _scene(p: float, e: float, v0: float, spc: int) -> AdapterScene:
    k = HERTZ_K if p == 1.5 else HOOKE_K
    pot = PowerLaw(k, p)
    zeta = zeta_from_restitution(e)
    t_c = solve_impact(pot, MASS, v0, zeta).contact_time
    return AdapterScene(
        name=f"issue-28-{'hertz' if p == 1.5 else 'hooke'}",
        kind="impact",
        potential=pot,
        potential_spec={"family": "power", "k": k, "p": p},
        mass=MASS,
        v0=v0,
        damping="universal",
        zeta=zeta,
        restitution_asked=e,  # the asked e itself (zeta's round trip may differ by an ulp)
        dt=t_c / spc,
        n_steps=4 * spc + 64,
        velocities=SPEEDS,
    )


def codes_table(codes=CODES, asked=ASKED, steps=STEPS_PER_CONTACT, speeds=SPEEDS, progress=None):
    """Rows of asked e -> delivered e for every code variant (see the module docstring).

    Parameters
    ----------
    codes : sequence of (code, adapter spec, p)
        Variants to run; default `CODES`.
    asked, steps, speeds : sequences
        Asked restitutions, steps per contact, impact speeds (m/s).
    progress : callable, optional
        ``progress(done, total)`` after each variant.

    Returns
    -------
    list of CodeRow
    """

    rows: list[CodeRow] = []
    for i, (code, spec, p) in enumerate(codes):
        for e in asked:
            rows += _typed_rows(code, spec, p, e, steps, speeds)
        if progress is not None:
            progress(i + 1, len(codes))
    return rows


def _typed_rows(code: str, spec: str, p: float, e: float, steps, speeds) -> list[CodeRow]:
    """The rows of one variant and one asked e, typed into the code as is (`typed_spec`)."""
    k = HERTZ_K if p == 1.5 else HOOKE_K
    run, added = typed_spec(spec, e, p)
    cells = [(n, v) for n in steps for v in speeds]
    try:
        ex = make_executor(run)
    except HCVInputError as exc:  # not installed, or a spec of another version
        return [CodeRow(code, spec, k, p, e, n, v, error=str(exc)) for n, v in cells]
    rows: list[CodeRow] = []
    try:
        label = ex.variants[0].label.replace(added, "") if added else ex.variants[0].label
        for n, v in cells:
            row = CodeRow(code, label, k, p, e, n, v)
            rows.append(row)
            s = _scene(p, e, v, n)
            reason = ex.variants[0].supports(s)
            if reason:
                row.error = f"declined: {reason}"
                continue
            out = ex.call(0, "impact", s, timeout=_TIMEOUT)
            if not out.ok:
                row.error = out.declined or out.error
                continue
            m = measure(out.value, v)
            row.delivered = float(m.get("restitution", math.nan))
            row.tensile = float(m.get("tensile", math.nan))
            law = ex.call(0, "implemented_law", s, timeout=_TIMEOUT)
            if law.ok:
                row.declared_exact = float(exact_reference(law.value, v)["restitution"])
    finally:
        ex.close()
    return rows


def calibration_table(codes=CALIBRATED, asked=ASKED, steps_per_contact: int = 200, v0=1.0):
    """The input that delivers each asked e (`reference_impl.bench.calibration.calibrate`), per code.

    ``codes`` items are (code, adapter spec, p, option[, (lo, hi)]): the range is the
    adapter's ``calibration_range`` unless given. Returns dicts with the code,
    variant, option, asked e, and either the value found
    (``found``, ``value``) or the span the code delivers over the option's range
    (``delivered``: "out of reach"), and the calibration's one-line ``message``. The
    searched option overrides the adapter's mapping of e; the code's other e inputs are
    typed as is (`typed_spec`: YADE ViscElMat's tc of the asked e).
    """

    rows = []
    for code, spec, p, param, *bracket in codes:  # an optional 5th item: the option's range
        k = HERTZ_K if p == 1.5 else HOOKE_K
        for e in asked:
            scene = scene_from_dict(
                {
                    "name": f"issue-28-{'hertz' if p == 1.5 else 'hooke'}",
                    "mass": MASS,
                    "velocities": [v0],
                    "kind": "impact",
                    "potential": {"family": "power", "k": k, "p": p},
                    "damping": {"law": "universal", "restitution": e},
                }
            )
            row = {"code": code, "variant": spec, "option": param, "asked": e}
            # the code's other e inputs as typed (YADE tc's contact time): only ``param``
            # is searched, and the adapter's own mapping of e must not move the rest
            run, _ = typed_spec(spec, e, p, keep=param)
            try:
                res = calibrate(run, scene, param=param, target=e, bracket=bracket[0] if bracket else None,
                                steps_per_contact=steps_per_contact, timeout=_TIMEOUT)  # fmt: skip
            except HCVInputError as exc:  # not installed, or declined
                row.update(found=False, error=str(exc))
            else:
                row.update(found=res.found, value=res.value, delivered=list(res.delivered),
                           message=res.message)  # fmt: skip
            rows.append(row)
    return rows
