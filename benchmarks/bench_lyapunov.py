"""Speed of the Lyapunov estimators, side by side in one run (issue 13, item 7).

    python benchmarks/bench_lyapunov.py [--revs 200] [--out benchmarks/results/lyapunov.md]

Measured (process CPU time, after a warm-up call that compiles everything):
1. cost of one tangent vector: ``run_tangent`` (k = 1) over N revolutions of slider_crank against
   the plain trajectory (``advance``) over the same revolutions, both at rtol 1e-10; with the
   tangent vector in the error control (default) and without;
2. slider_crank lambda1 to a relative uncertainty of 5 % (``target_uncertainty=0.05``, at least
   100 revolutions): CPU time, revolutions averaged, value;
3. the two-trajectory estimate over the same revolutions, for comparison;
4. Lorenz lambda1 over 100 time units (DynamicalSystems.jl quotes 23 ms on its own machine).
Ratios are what to compare across machines; absolute times depend on the machine and its load.
"""
from __future__ import annotations

import argparse
import platform
import time
from pathlib import Path

import numpy as np

from nld.analysis.lyapunov import lyapunov_benettin, lyapunov_tangent
from nld.systems.core import SceneSystem, advance, lorenz
from nld.systems.tangent import run_tangent


def cpu(f, repeat=1):
    best = np.inf
    out = None
    for _ in range(repeat):
        t = time.process_time()
        out = f()
        best = min(best, time.process_time() - t)
    return best, out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--revs", type=float, default=100.0)
    ap.add_argument("--out", default=str(Path(__file__).parent / "results" / "lyapunov.md"))
    a = ap.parse_args(argv)
    S = SceneSystem("slider_crank")
    T = S.period
    y, z = advance(S, S.y0, S.z0, 0.0, 20 * T, 1e-10)
    W = (np.eye(S.n)[:1] * S.scales).copy()
    Wz = np.zeros((1, z.size))
    t0, t1 = 20 * T, (20 + a.revs) * T
    marks = t0 + T / 8 * np.arange(1, int(round(a.revs * 8)) + 1)
    # warm-up (compilation)
    advance(S, y, z, t0, t0 + T, 1e-10)
    run_tangent(S, y, z, W, Wz, t0, marks[:8], 1e-10)
    lyapunov_tangent(lorenz(), total=5.0)
    c_plain, _ = cpu(lambda: advance(S, y, z, t0, t1, 1e-10), 3)
    c_tan, r_tan = cpu(lambda: run_tangent(S, y, z, W, Wz, t0, marks, 1e-10), 3)
    c_tan0, r_tan0 = cpu(lambda: run_tangent(S, y, z, W, Wz, t0, marks, 1e-10,
                                             tangent_err=False), 3)
    c_target, r = cpu(lambda: lyapunov_tangent(S, transient=20 * T, total=100 * T,
                                                target_uncertainty=0.05, max_total=2000 * T))
    c_target0, r0 = cpu(lambda: lyapunov_tangent(S, transient=20 * T, total=100 * T,
                                                  target_uncertainty=0.05, max_total=2000 * T,
                                                  tangent_err=False))
    revs_avg = r.settings["total"] / T
    c_ben, b = cpu(lambda: lyapunov_benettin(S, transient=20 * T, total=revs_avg * T))
    c_lor, lo = cpu(lambda: lyapunov_tangent(lorenz(), total=100.0), 5)
    lines = [
        "# Lyapunov estimators: speed (benchmarks/bench_lyapunov.py)",
        "",
        f"Machine: {platform.machine()}, {platform.processor() or platform.system()}; process CPU "
        "time after compilation, best of 3 where repeated.",
        "",
        "| measurement | CPU time | ratio | result |",
        "|---|---|---|---|",
        f"| slider_crank plain trajectory, {a.revs:g} rev, rtol 1e-10 | {c_plain:.2f} s | 1 | |",
        f"| + 1 tangent vector, in the error control (default) | {c_tan:.2f} s | "
        f"{c_tan / c_plain:.2f} | {int(r_tan.stats[1])} steps |",
        f"| + 1 tangent vector, state-only error control | {c_tan0:.2f} s | "
        f"{c_tan0 / c_plain:.2f} | {int(r_tan0.stats[1])} steps |",
        f"| slider_crank lambda1 to 5 % (tangent, default) | {c_target:.2f} s | | "
        f"{r.per_revolution:.3f} +- {r.uncertainty_per_revolution:.3f} per rev over "
        f"{revs_avg:.0f} rev, target reached: {r.settings['target_reached']} |",
        f"| slider_crank lambda1 to 5 % (tangent, state-only error control) | {c_target0:.2f} s "
        f"| | {r0.per_revolution:.3f} +- {r0.uncertainty_per_revolution:.3f} per rev over "
        f"{r0.settings['total'] / T:.0f} rev, target reached: {r0.settings['target_reached']} |",
        f"| slider_crank lambda1, two trajectories, same revolutions | {c_ben:.2f} s | "
        f"{c_ben / c_target:.2f} | {b.per_revolution:.3f} +- {b.uncertainty_per_revolution:.3f} |",
        f"| Lorenz lambda1, 100 time units (tangent) | {1000 * c_lor:.1f} ms | "
        f"{c_lor / 0.023:.2f} x 23 ms | {lo.exponent:.4f} +- {lo.uncertainty:.3f} |",
        "",
    ]
    text = "\n".join(lines)
    print(text)
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(text + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
