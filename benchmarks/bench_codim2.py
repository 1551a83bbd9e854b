"""Cost of a period-doubling curve on slider_crank_olyaei (issue 41): the doubling in the
clearance at mu = 0.1 (the permanent-contact period-1 orbit reached from c = 0.28 mm regains
stability through -1 near c = 0.28613 mm: tests/test_continuation.py) followed in the friction
coefficient mu by ``nld.analysis.codim2.continue_bifurcation``.

Run: ``python benchmarks/bench_codim2.py [N]`` (N: points per direction, default 5; writes
benchmarks/results/codim2.md). Wall seconds on this machine (compilation included in the
locating step only); revolutions integrated = the curve's ``settings["integrations"]`` (each a
revolution with the tangent integration), compared with the wall time of plain revolutions.
"""
from __future__ import annotations

import os
import platform
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _results import write_table  # noqa: E402

RTOL = 1e-10
CLEAR = "joints.B.clearance"
MU = "joints.B.friction.mu"


def main(n_points: int = 5):
    from nld.analysis.codim2 import continue_bifurcation
    from nld.analysis.continuation import continue_orbit
    from nld.analysis.orbits import periodic_orbit, section_points
    from nld.systems import SceneSystem
    from nld.systems.derived import StroboscopicMap
    t = time.perf_counter()
    S = SceneSystem("slider_crank_olyaei", [f"{CLEAR}=0.28e-3"])
    o1 = periodic_orbit(S, 1, transient=100, rtol=RTOL)
    br = continue_orbit(S, o1, CLEAR, [0.28e-3, 0.2835e-3, 0.287e-3, 0.29e-3],
                        locate_tol=2e-8, criticality=False)
    pd = [b for b in br.bifurcations if b.kind == "period_doubling"][0]
    t_locate = time.perf_counter() - t
    print(f"doubling at c = {pd.value:.9g} +- {pd.tolerance:.2g} m ({t_locate:.1f} s)", flush=True)
    m = StroboscopicMap(S, 1, RTOL)
    t = time.perf_counter()
    section_points(m, m.y0, m.z0, 21)
    rev = (time.perf_counter() - t) / 20
    t = time.perf_counter()
    c = continue_bifurcation(S, pd, MU, (0.09, 0.11), param=CLEAR, stops=(0.095, 0.105),
                             max_points=n_points + 1,
                             progress=lambda i, n, v1, v2: print(
                                 f"  {i}: c = {v1:.9g} m, mu = {v2:.6g} "
                                 f"({time.perf_counter() - t:.1f} s)", flush=True))
    wall = time.perf_counter() - t
    npts = len(c.values1)
    head = ["# codim2: a period-doubling curve on slider_crank_olyaei", "",
            f"Machine: {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs; "
            f"`python benchmarks/bench_codim2.py {n_points}`; rtol {RTOL:g}.", "",
            f"Start: doubling in {CLEAR} at mu = 0.1: {pd.value:.9g} +- {pd.tolerance:.2g} m "
            f"(located in {t_locate:.1f} s, compilation included).", "",
            f"Curve in {MU} over (0.09, 0.11): {npts} points, {wall:.1f} s wall, "
            f"{c.settings['integrations']} revolutions integrated (with tangents); a plain "
            f"revolution {rev * 1e3:.1f} ms; {wall / max(npts - 1, 1):.1f} s per point. "
            f"Message: {c.message}", "",
            "| c (m) | mu | tolerance1 (m) | condition g | abs(mu_c + 1) | landed | onsets/rev | continuum |",
            "|---|---|---|---|---|---|---|---|"]
    rows = [f"| {v1:.9g} | {v2:.6g} | {tl:.2g} | {g:.2g} | {d:.2g} | {ld} | "
            f"{o.onsets_per_period} | {o.continuum} |"
            for v1, v2, tl, g, d, ld, o in zip(c.values1, c.values2, c.tolerance1, c.condition,
                                               c.distance, c.landed, c.orbits)]
    rows += ["", "Special points: " + ("; ".join(f"{s.kind} at ({s.value1:.6g}, {s.value2:.4g})"
                                                 for s in c.special_points) or "none")]
    write_table(Path(__file__).resolve().parent / "results" / "codim2.md", head, rows)


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 5)
