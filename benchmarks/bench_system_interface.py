#!/usr/bin/env python
"""Warm speed of the paths through nld.systems' integrator call (issue 39), for a before/after
comparison of a refactoring.

    python benchmarks/bench_system_interface.py --out times_A.json     # time this tree
    python benchmarks/bench_system_interface.py --report A1.json A2.json --against B1.json B2.json
                                                [--out results.md]

Each case is run once to warm up (compilation excluded), then ``--repeats`` times; the minimum
CPU time of the process is kept (on a shared machine wall time also counts waiting for a core,
and the minimum is the least disturbed run). The report puts
two trees' times side by side with the ratio B / A. Run the two trees alternately (A, B, A, B)
and keep each one's minimum over its runs, so that a change in the machine's load does not pass
for a change of speed.

Cases (CPU s per repeat, warm):
  simulate        nld.run.simulate slider_crank, 20 revolutions (the chunked integration);
  strobe_steps    10 stroboscopic map steps of slider_crank at rtol 1e-10 (one landing
                  integration each);
  strobe_jacobian 3 stroboscopic steps with the tangent integrator (jacobian=True);
  advance_duffing 200 advance() calls of one forcing period of Duffing (per-call overhead);
  poincare_lorenz 20 Poincare map steps of Lorenz (Brent on landing integrations);
  orbit           period-1 orbit of slider_crank_olyaei (10-revolution transient, rtol 1e-10);
  census          census of the forced double well, 8 starts;
  tangent_lyap    lyapunov_tangent of slider_crank, 10 revolutions after 2;
  trajectory      trajectory() of slider_crank, 40 samples over 2 revolutions.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))
from _results import write_table  # noqa: E402


def cases():
    from nld.analysis.attractors import census
    from nld.analysis.lyapunov import lyapunov_tangent
    from nld.analysis.orbits import periodic_orbit
    from nld.run.simulate import simulate
    from nld.systems import PoincareMap, SceneSystem, StroboscopicMap, advance, duffing, lorenz, trajectory
    sc = SceneSystem("slider_crank")
    olyaei = SceneSystem("slider_crank_olyaei")
    m = StroboscopicMap(sc, 1, 1e-10)
    D = duffing()
    L = lorenz()
    P = PoincareMap(L, [0.0, 0.0, 1.0], 27.0, +1, rtol=1e-10)
    well = duffing(delta=0.5, alpha=-1.0, beta=1.0, gamma=0.1, omega=1.4)

    def strobe(n, jac=False):
        x, z = m.y0, m.z0
        for _ in range(n):
            st = m.step(x, z, jacobian=jac, relabel=True)
            x, z = st.x, st.z

    def adv():
        y, z = D.y0, D.z0
        for k in range(200):
            y, z = advance(D, y, z, 0.0, D.period, 1e-10)

    def poinc():
        x = P.y0
        for _ in range(20):
            x = P.step(x, P.z0).x

    T = sc.period
    return {
        "simulate": lambda: simulate("slider_crank", revs=20, progress=False),
        "strobe_steps": lambda: strobe(10),
        "strobe_jacobian": lambda: strobe(3, True),
        "advance_duffing": adv,
        "poincare_lorenz": poinc,
        "orbit": lambda: periodic_orbit(olyaei, 1, transient=10, rtol=1e-10),
        "census": lambda: census(well, 8, sampler=((-1.5, -1.0), (1.5, 1.0)), transient=30,
                                 record=32, progress=False),
        "tangent_lyap": lambda: lyapunov_tangent(sc, 1, transient=2 * T, total=10 * T,
                                                 target_uncertainty=None),
        "trajectory": lambda: trajectory(sc, 40, T / 20),
    }


def run(out: str, repeats: int, only=None) -> None:
    res = {}
    for name, fn in cases().items():
        if only and name not in only:
            continue
        fn()
        best = float("inf")
        for _ in range(repeats):
            t = time.process_time()
            fn()
            best = min(best, time.process_time() - t)
        res[name] = best
        print(f"{name:16s} {best:.4f} s", flush=True)
    Path(out).write_text(json.dumps(res, indent=1))


def merge(paths):
    """Per case, the minimum over several timing files of one tree."""
    best = {}
    for p in paths:
        for k, v in json.loads(Path(p).read_text()).items():
            best[k] = min(best.get(k, float("inf")), v)
    return best


def report(a_paths, b_paths, out, command: str) -> None:
    A, B = merge(a_paths), merge(b_paths)
    head = ["# Warm speed through nld.systems' integrator call, before / after (issue 39)", "",
            f"Command: `{command}`", "",
            f"Machine: {platform.machine()}, {os.cpu_count()} CPUs (shared: other jobs were "
            f"running), Python {platform.python_version()}. CPU seconds of the process, minimum "
            f"over the repeats of every run of each tree (runs alternated A, B, A, B); ratio B / A.", "",
            "| case | A (s) | B (s) | B / A |", "|---|---:|---:|---:|"]
    rows = [f"| {k} | {A[k]:.4f} | {B[k]:.4f} | {B[k] / A[k]:.3f} |" for k in A if k in B]
    write_table(out, head, rows)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", help="timing JSON (or, with --report, the markdown) to write")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--only", nargs="+")
    ap.add_argument("--report", nargs="+", metavar="A.json", help="tree A's timing files")
    ap.add_argument("--against", nargs="+", metavar="B.json", help="tree B's timing files")
    ap.add_argument("--command", default="", help="(report) the command line to cite")
    a = ap.parse_args(argv)
    if a.report:
        report(a.report, a.against, a.out or str(HERE / "results" / "system_interface.md"),
               a.command)
        return 0
    run(a.out or "times.json", a.repeats, a.only)
    return 0


if __name__ == "__main__":
    sys.exit(main())
