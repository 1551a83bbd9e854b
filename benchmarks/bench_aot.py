#!/usr/bin/env python
"""The integrator cores built at install against numba's JIT build of the same cores, warm.

    python benchmarks/bench_aot.py [--out benchmarks/results/aot.md]

One process; each run alternates the two builds (``NLD_AOT=1`` / ``0``, nld.integrators.aot),
both warmed first; the figure is the minimum process CPU time over the repeats. DOPRI5
trajectories through the kernel's solve at rtol 1e-8 and tangent runs (one vector, rtol 1e-10),
slider_crank over 2 and 20 revolutions and the excavator over half a revolution. Both builds must
give the same result (checked: the largest difference is printed, 0 expected). Needs the built
cores (``python -m nld.integrators.aot_build``).
"""
from __future__ import annotations

import argparse
import datetime
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

from _results import write_table  # noqa: E402 (benchmarks/_results.py)

HERE = Path(__file__).resolve().parent
CASES = [("slider_crank", 2.0), ("slider_crank", 20.0), ("excavator", 0.5)]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(HERE / "results" / "aot.md"))
    ap.add_argument("--repeats", type=int, default=5)
    a = ap.parse_args(argv)
    from nld.integrators import aot
    from nld.systems.core import SceneSystem
    from nld.systems.tangent import run_tangent
    if aot.why_not():
        raise SystemExit(f"the built cores are not usable: {aot.why_not()}")
    t_all = time.time()
    rows = []
    for scene, revs in CASES:
        S = SceneSystem(scene)
        m = S.kernel.module
        te = np.linspace(0.0, revs * S.period, 50)

        def traj():
            r = m.solve(0.0, S.y0.copy(), te, False, S.p, S.z0.copy(), 1e-8, S.tolerance(1e-8),
                        0.0, float(S.hmax), 10**8, S.n_events, 100000)
            return r.Y[-1]

        def tan():
            W = (np.eye(S.n)[:1] * S.scales).copy()
            r = run_tangent(S, S.y0.copy(), S.z0.copy(), W, np.zeros((1, S.z0.size)), 0.0,
                            revs * S.period / 4 * np.arange(1, 5), 1e-10)
            return np.concatenate([r.y, r.logs.ravel()])

        for work, f in (("trajectory", traj), ("tangent", tan)):
            best, value = {}, {}
            for mode in ("1", "0"):
                os.environ["NLD_AOT"] = mode
                value[mode] = f()
            for _ in range(a.repeats if work == "trajectory" else max(2, a.repeats // 2)):
                for mode in ("1", "0"):
                    os.environ["NLD_AOT"] = mode
                    t = time.process_time()
                    f()
                    best[mode] = min(best.get(mode, np.inf), time.process_time() - t)
            d = float(np.nanmax(np.abs(value["1"] - value["0"])))
            rows.append(f"| {scene} | {revs:g} | {work} | {1e3 * best['1']:.2f} | "
                        f"{1e3 * best['0']:.2f} | {best['1'] / best['0']:.3f} | {d:.1e} |")
            print(rows[-1], flush=True)
    os.environ.pop("NLD_AOT", None)
    head = [
        "# Cores built at install against the JIT's, warm (issue 23)",
        "",
        f"Command: `python benchmarks/bench_aot.py --repeats {a.repeats}`; "
        f"{datetime.datetime.now():%Y-%m-%d %H:%M}, {os.cpu_count()} cores, "
        f"{platform.processor() or platform.machine()}; {time.time() - t_all:.0f} s.",
        "",
        "Minimum process CPU time (ms), the two builds alternating in one process; 'max abs d': "
        "the largest difference of the final states (and tangent logs) between them.",
        "",
        "| scene | revolutions | work | built (ms) | JIT (ms) | built / JIT | max abs d |",
        "|---|---|---|---|---|---|---|",
    ]
    write_table(a.out, head, rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
