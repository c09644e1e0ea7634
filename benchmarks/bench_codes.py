"""Cost of a run of the Debian codes, persistent against a process per run (YADE, LIGGGHTS).

Run:  python -m benchmarks.bench_codes [--runs N] [--json FILE]

The hertz-damped scene at its middle speed (200 steps per contact), N impacts each,
interleaved in one process so that the machine's load hits all alike:

* ``yade[en,wall]``: one YADE process for all runs (persistent mode; its start-up,
  ~3 s, is paid once, before the timing);
* ``yade[en,wall,persistent=false]``: a YADE process per run (what a one-shot
  ``cmd:`` adapter costs);
* ``liggghts[hertz,wall]``: one LIGGGHTS for all runs (runs separated by ``clear``);
* ``liggghts[hertz,wall,persistent=false]``: a LIGGGHTS process per run (~0.6 s).

Reported: seconds per run of each (the fastest of N: the least disturbed by the load), the
ratio one-shot / persistent, the gate time it implies for the default scenes (93 runs per
variant: an extrapolation, not a gate's time; ``bench_startup --docs`` times the gates),
and the 1-minute load before and after (issue 41: every timing with its load). Goal (issue 28): a
YADE gate over the default scenes <= 180 s (from 654 s with a YADE per run).
"""

from __future__ import annotations

import argparse
import os
import time

from benchmarks._machine import machine_info
from benchmarks._record import write_json
from reference_impl import solve_impact
from reference_impl.adapters import AdapterScene, get_adapter
from reference_impl.scenes import load_scene

_RUNS_PER_VARIANT = 93  # the default scenes' runs per variant (docs/adapter-protocol.md)


def _scene() -> AdapterScene:
    sc = load_scene("hertz-damped")
    v0 = sc.velocities[len(sc.velocities) // 2]
    t_c = solve_impact(sc.potential, sc.mass, v0, sc.zeta).contact_time
    return AdapterScene.from_scene(sc, v0, t_c / 200, 864)


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--json")
    args = ap.parse_args(argv)
    load_before = os.getloadavg()[0]
    scene = _scene()
    specs = [
        "yade[en,wall]",
        "yade[en,wall,persistent=false]",
        "liggghts[hertz,wall]",
        "liggghts[hertz,wall,persistent=false]",
    ]
    adapters, seconds = {}, {}
    for spec in specs:
        try:
            adapters[spec] = get_adapter(spec)
        except Exception as exc:  # not installed: reported, not fatal
            print(f"{spec}: skipped ({exc})")
    for spec in ("yade[en,wall]", "liggghts[hertz,wall]"):
        if spec in adapters:
            adapters[spec].impact(scene)  # start-up paid once, before timing
    for spec in adapters:
        seconds[spec] = []
    for _ in range(args.runs):  # interleaved: the load hits every code alike
        for spec, ad in adapters.items():
            t0 = time.perf_counter()
            ad.impact(scene)
            seconds[spec].append(time.perf_counter() - t0)
    for ad in adapters.values():
        ad.close()
    out = {
        "benchmark": "codes",
        "machine": machine_info(),
        "runs": args.runs,
        "per_run_s": {},
        "gate_s": {},
        "load_average_1min": {"before": load_before, "after": os.getloadavg()[0]},
        "generated_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
    }
    for spec, s in seconds.items():
        per = min(s)
        out["per_run_s"][spec] = per
        out["gate_s"][spec] = per * _RUNS_PER_VARIANT
        print(f"{spec:35s} {per:8.4f} s a run, ~{per * _RUNS_PER_VARIANT:7.1f} s for 93 runs")
    out["ratio_one_shot_over_persistent"] = {}
    for code, b in (("yade", "yade[en,wall]"), ("liggghts", "liggghts[hertz,wall]")):
        a = b[:-1] + ",persistent=false]"
        if a in seconds and b in seconds:
            ratio = min(seconds[a]) / min(seconds[b])
            out["ratio_one_shot_over_persistent"][code] = ratio
            print(f"{code}: one-shot / persistent {ratio:.0f} x")
    if args.json:
        write_json(args.json, out)
    return out


if __name__ == "__main__":
    main()
