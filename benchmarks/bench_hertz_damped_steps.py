"""Where slider_crank's hertz_damped run spends its steps and its time (issue 14, stop 21).

    python benchmarks/bench_hertz_damped_steps.py [--rtol 1e-8 1e-10] [--repeats 200]

slider_crank with hertz_damped contact (C = 400 N s/m), 0.25 revolution from the assembled state,
called as benchmarks/bench_methods.py calls it (the generated solve wrappers, 2 output times, the
tolerance vector computed once). For dopri5 and dop853 at each rtol, with the default interior
event samples and with the step's ends only (event_samples = 0), side by side in one run: the
CPU time (min over repeats), accepted + rejected steps, rhs evaluations and the largest
journal-centre error to a dop853/dopri5 reference at rtol 1e-12 (/ clearance). Prints a table,
then the kernel's rhs and events per call (ns, a numba loop of 2e6 calls) in free and contact mode.
"""
from __future__ import annotations

import argparse
import runpy
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rtol", type=float, nargs="+", default=[1e-8, 1e-10])
    ap.add_argument("--repeats", type=int, default=200)
    a = ap.parse_args(argv)
    from nld.integrators import EVENT_SAMPLES, solve_method
    from nld.run.simulate import tolerances
    wp = runpy.run_path(str(ROOT / "studies" / "work_precision.py"))
    bm = runpy.run_path(str(ROOT / "benchmarks" / "bench_methods.py"))
    s = bm["make_setup"]("slider_crank", 0.25, bm["settings"](True), tuple(bm["HD"].items()))
    refs = bm["reference"](s)
    ends = np.array([0.0, s.t_window])

    def run(m, rtol, es, t_eval, atol):
        z = np.array(s.z0, float)
        return solve_method(s.kern, m, 0.0, np.ascontiguousarray(s.y0, float), t_eval, False, s.p, z,
                            rtol, atol, 0.0, float(s.period / 20), 20_000_000, int(s.kern.n_events),
                            100_000, es)

    print("| method | rtol | event_samples | CPU (ms) | accepted + rejected | rhs | err / c |")
    print("|---|---|---|---|---|---|---|")
    for m in ("dopri5", "dop853"):
        ref = refs[next(r for r in refs if r != m)]
        for rtol in a.rtol:
            atol = tolerances(s.kern, s.q, rtol)
            for es in (EVENT_SAMPLES, 0):
                run(m, rtol, es, ends, atol)
                best = float("inf")
                for _ in range(a.repeats):
                    t0 = time.process_time()
                    out = run(m, rtol, es, ends, atol)
                    best = min(best, time.process_time() - t0)
                fine = run(m, rtol, es, s.t_win_eval, atol)
                err = wp["window_measures"](s, s.observe(s.t_win_eval, fine), s.events(fine),
                                            *ref)["journal_err_rel"]
                st = out[4]
                print(f"| {m} | {rtol:.0e} | {es} | {best * 1e3:.3f} | {st[1]} + {st[2]} | {st[3]} | "
                      f"{err:.2e} |", flush=True)
    print()
    print("| function | mode | ns per call |")
    print("|---|---|---|")
    for name, mode, ns in per_call_ns(s):
        print(f"| {name} | {mode} | {ns:.1f} |")


def per_call_ns(s, n=2_000_000):
    """ns per call of the kernel's rhs and events, free (z = 0) and contact mode (z = 1)."""
    from numba import njit

    @njit
    def loop(f, y, p, z, out, n):
        acc = 0.0
        for i in range(n):
            y[0] += 1e-15
            f(1e-3 * i, y, p, z, out)
            acc += out[0]
        return acc
    m = s.kern.module
    y = np.ascontiguousarray(s.y0, float).copy()
    rows = []
    for mode in (0.0, 1.0):
        z = np.array(s.z0, float)
        z[:] = mode
        for name, f, out in (("rhs", m.rhs, np.empty(y.size)), ("events", m.events, np.empty(s.kern.n_events))):
            loop(f, y, s.p, z, out, 10)
            t0 = time.perf_counter()
            loop(f, y, s.p, z, out, n)
            rows.append((name, "free" if mode == 0.0 else "contact", (time.perf_counter() - t0) / n * 1e9))
    return rows


if __name__ == "__main__":
    main()
