"""Five codes side by side: asked restitution -> delivered restitution (issue 28).

For every built-in code (LAMMPS, LIGGGHTS, Kratos DEM, YADE, MuJoCo) and the
variants users run, the impact of issue 28's sphere (m = 4.1103 g; Hertz
k = 1.0879e10 N/m^1.5 or, for the linear codes, Hooke k = 1e6 N/m) on a wall is
run with each asked restitution, at 20 and 200 steps per contact and at two
speeds four decades apart. Each row keeps the delivered restitution (q = 0 end),
the tensile force at the end of contact (max pull / peak push) and the exact
restitution of the law the code declares. Codes that are not installed give one
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
from reference_impl.bench.calibrate import calibrate
from reference_impl.bench.measure import exact_reference, measure
from reference_impl.bench.worker import make_executor
from reference_impl.errors import HCVInputError
from reference_impl.exact.solve import solve_impact
from reference_impl.potentials.power import PowerLaw
from reference_impl.scenes import scene_from_dict
from reference_impl.theory.damping import zeta_from_restitution

__all__ = ["ASKED", "CALIBRATED", "CODES", "CodeRow", "calibration_table", "codes_table"]

MASS = 4.1103e-3  # kg: 10 mm steel sphere
HERTZ_K = 1.0879e10  # N/m^1.5: on a steel wall (E* = 115.4 GPa, R = 5 mm)
HOOKE_K = 1.0e6  # N/m: the bench's linear scene
ASKED = (0.9, 0.5, 0.2)
STEPS_PER_CONTACT = (200, 20)
SPEEDS = (0.01, 100.0)  # m/s, four decades apart
# (code, adapter spec, p): the variants users run, on a wall.
CODES = (
    ("LAMMPS", "lammps[damping=coeff_restitution,geometry=wall]", 1.5),
    ("LAMMPS", "lammps[damping=coeff_restitution,geometry=wall,limit_damping=true]", 1.5),
    ("LAMMPS", "lammps[damping=tsuji,geometry=wall]", 1.5),
    ("LIGGGHTS", "liggghts[hertz,wall]", 1.5),
    ("LIGGGHTS", "liggghts[hertz,wall,limit_force=true]", 1.5),
    ("Kratos DEM", "kratos[law=hertz,scheme=verlet]", 1.5),
    ("YADE", "yade[en,wall]", 1.5),
    ("YADE", "yade[tc,wall]", 1.0),
    ("YADE", "yade[kn,wall]", 1.0),
    ("MuJoCo", "mujoco[solref=timeconst,impedance=constant,integrator=Euler]", 1.0),
)
_TIMEOUT = 120.0  # s per run
# (code, adapter spec with its keys, p, option searched): the input that delivers e.
CALIBRATED = (
    ("LIGGGHTS", "liggghts[model=hertz,geometry=wall,limit_force=true]", 1.5, "restitution"),
    ("Kratos DEM", "kratos[law=hertz,scheme=verlet]", 1.5, "restitution"),
    ("YADE", "yade[input=en,geometry=wall]", 1.5, "en"),
    ("YADE", "yade[input=tc,geometry=wall]", 1.0, "en"),
    ("MuJoCo", "mujoco[solref=timeconst,impedance=constant,integrator=Euler]", 1.0, "dampratio"),
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
        k = HERTZ_K if p == 1.5 else HOOKE_K
        cells = [(e, n, v) for e in asked for n in steps for v in speeds]
        try:
            ex = make_executor(spec)
        except HCVInputError as exc:  # not installed, or a spec of another version
            rows += [CodeRow(code, spec, k, p, e, n, v, error=str(exc)) for e, n, v in cells]
            continue
        try:
            label = ex.variants[0].label
            for e, n, v in cells:
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
        if progress is not None:
            progress(i + 1, len(codes))
    return rows


def calibration_table(codes=CALIBRATED, asked=ASKED, steps_per_contact: int = 200, v0=1.0):
    """The input that delivers each asked e (`reference_impl.bench.calibrate`), per code.

    ``codes`` items are (code, adapter spec, p, option[, (lo, hi)]): the range is the
    adapter's ``calibration_range`` unless given. Returns dicts with the code,
    variant, option, asked e, and either the value found
    (``found``, ``value``) or the span the code delivers over the option's range
    (``delivered``: "out of reach"), and the calibration's one-line ``message``.
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
            try:
                res = calibrate(spec, scene, param=param, target=e, bracket=bracket[0] if bracket else None,
                                steps_per_contact=steps_per_contact, timeout=_TIMEOUT)  # fmt: skip
            except HCVInputError as exc:  # not installed, or declined
                row.update(found=False, error=str(exc))
            else:
                row.update(found=res.found, value=res.value, delivered=list(res.delivered),
                           message=res.message)  # fmt: skip
            rows.append(row)
    return rows
