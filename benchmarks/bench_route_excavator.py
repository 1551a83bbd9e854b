"""Cost of the excavator's periodic orbits (issue 40, docs/route.md), in plain revolutions.

The period-1 orbit of scene ``excavator`` with both clearances set to r (r1 = r2, as the study's
clearance sweep sets them) at r = 3 and 5 µm, from the state after a 10-revolution run (Newton
shooting with the monodromy matrix and the multipliers' second evaluation at 10 rtol), against one
plain revolution (stroboscopic map without Jacobian) at the same rtol: 'cost in revs' = orbit time /
plain revolution (the 10-revolution transient included). Times are CPU seconds of this process
(time.process_time: the machine may be shared), after a warm-up call (no compilation).

Run: ``python benchmarks/bench_route_excavator.py`` (writes benchmarks/results/route_excavator.md).
"""
from __future__ import annotations

import os
import platform
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _results import write_table  # noqa: E402

RTOL = 1e-8
CLEARANCES = (3e-6, 5e-6)


def system(r):
    from nld.systems.core import SceneSystem
    return SceneSystem("excavator", [f"joints.A.clearance={r!r}", f"joints.B.clearance={r!r}"])


def plain_rev_cpu(S, revs=10):
    from nld.analysis.orbits import section_points
    from nld.systems.derived import StroboscopicMap
    m = StroboscopicMap(S, 1, RTOL)
    section_points(m, m.y0, m.z0, 2)
    t = time.process_time()
    section_points(m, m.y0, m.z0, revs + 1)
    return (time.process_time() - t) / revs


def main():
    from nld.analysis.orbits import periodic_orbit
    rows = []
    for r in CLEARANCES:
        S = system(r)
        periodic_orbit(S, 1, transient=10, rtol=RTOL)            # warm-up
        t = time.process_time()
        o = periodic_orbit(S, 1, transient=10, rtol=RTOL)
        cpu = time.process_time() - t
        rev = plain_rev_cpu(S)
        rows.append(f"| r1 = r2 = {r * 1e6:g} µm | {'yes' if o.converged else 'no: ' + o.message} | "
                    f"{o.iterations} | {o.residual:.1e} | {cpu:.1f} | {rev * 1e3:.0f} | "
                    f"{cpu / rev:.0f} | {o.onsets_per_period} | {o.max_abs_multiplier:.4g} |")
        print(rows[-1], flush=True)
    head = ["# The excavator's period-1 orbits: cost in plain revolutions", "",
            f"`python benchmarks/bench_route_excavator.py`, rtol {RTOL:g}, {platform.machine()} "
            f"{os.cpu_count()} cores, Python {platform.python_version()}. CPU seconds after a "
            "warm-up call; 'plain rev' one revolution without Jacobian at the same rtol; 'cost in "
            "revs' = orbit / plain rev (the 10-revolution transient and the multipliers' check at "
            "10 rtol included).", "",
            "| case | converged | Newton steps | residual | CPU (s) | plain rev (ms) | cost in revs | onsets/period | max abs mu |",
            "|---|---|---|---|---|---|---|---|---|"]
    write_table(Path(__file__).resolve().parent / "results" / "route_excavator.md", head, rows)


if __name__ == "__main__":
    main()
