"""Cost of periodic orbits and continuation (issue 24), warm, side by side with plain integration.

* a period-1 orbit of slider_crank_olyaei from a 10-revolution transient guess (Newton steps, wall
  time, and the wall time of plain revolutions at the same rtol: the orbit's cost in revolutions);
* the same for the impact oscillator and for slider_crank (impacting, 2 onsets per revolution);
* a 50-point natural continuation of slider_crank_olyaei in the friction coefficient (0.1 -> 0.05)
  without and with the location of the bifurcations.

Run: ``python benchmarks/bench_orbits.py`` (writes benchmarks/results/orbits.md). Times are
wall seconds on this machine, after a warm-up call of every function (compilation excluded).
"""
from __future__ import annotations

import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _results import write_table  # noqa: E402

RTOL = 1e-10


def plain_rev_time(S, revs=20):
    from nld.systems.derived import StroboscopicMap
    from nld.analysis.orbits import section_points
    m = StroboscopicMap(S, 1, RTOL)
    section_points(m, m.y0, m.z0, 2)
    t = time.perf_counter()
    section_points(m, m.y0, m.z0, revs + 1)
    return (time.perf_counter() - t) / revs


def orbit_case(name, S, **kw):
    from nld.analysis.orbits import periodic_orbit
    periodic_orbit(S, 1, rtol=RTOL, **kw)               # warm-up
    t = time.perf_counter()
    o = periodic_orbit(S, 1, rtol=RTOL, **kw)
    wall = time.perf_counter() - t
    rev = plain_rev_time(S)
    return (f"| {name} | {'yes' if o.converged else 'no: ' + o.message} | {o.iterations} | "
            f"{o.residual:.1e} | {wall:.2f} | {rev * 1e3:.1f} | "
            f"{wall / rev:.0f} | {o.onsets_per_period} | "
            f"{o.max_abs_multiplier:.4g}{' (continuum)' if o.continuum else ''} |"), o


def main():
    from nld.analysis.continuation import continue_orbit
    from nld.analysis.orbits import periodic_orbit
    from nld.systems import SceneSystem, impact_oscillator
    rows = []
    olyaei = SceneSystem("slider_crank_olyaei")
    r, o_oly = orbit_case("slider_crank_olyaei (defaults), 10-rev transient guess", olyaei,
                          transient=10)
    rows.append(r)
    r, _ = orbit_case("slider_crank (chaotic at its defaults: no period-1 orbit expected), 10-rev transient guess",
                      SceneSystem("slider_crank"), transient=10)
    rows.append(r)
    r, _ = orbit_case("impact oscillator, guess (1, 0.5)", impact_oscillator(), guess=[1.0, 0.5])
    rows.append(r)
    vals = np.linspace(0.1, 0.05, 50)
    crow = []
    for locate in (False, True):
        t = time.perf_counter()
        br = continue_orbit(olyaei, o_oly, "joints.B.friction.mu", vals, locate=locate)
        wall = time.perf_counter() - t
        crow.append(f"| 50 values of mu, 0.1 -> 0.05, natural{', bifurcations located' if locate else ''} | "
                    f"{len(br.values)} | {len(br.bifurcations)} | {wall:.1f} | "
                    f"{', '.join(sorted(set(b.kind for b in br.bifurcations))) or '-'} |")
    head = ["# Periodic orbits and continuation: cost (warm)", "",
            f"`python benchmarks/bench_orbits.py`, rtol {RTOL:g}, "
            f"{platform.machine()} {os.cpu_count()} cores, Python {platform.python_version()}. "
            "Wall seconds after a warm-up call (no compilation). 'plain rev' is one revolution "
            "of plain integration (stroboscopic map without Jacobian) at the same rtol; "
            "'cost in revs' = orbit wall / plain rev (the transient included).", "",
            "| case | converged | Newton steps | residual | wall (s) | plain rev (ms) | cost in revs | onsets/period | max abs mu |",
            "|---|---|---|---|---|---|---|---|---|"]
    rows += ["", "| continuation of slider_crank_olyaei's period-1 orbit | points | bifurcations | wall (s) | kinds |",
             "|---|---|---|---|---|"] + crow
    write_table(Path(__file__).resolve().parent / "results" / "orbits.md", head, rows)


if __name__ == "__main__":
    main()
