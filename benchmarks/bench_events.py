#!/usr/bin/env python
"""Cost and effect of scanning every step's dense output for event sign changes (issue 13 item 5).

    python benchmarks/bench_events.py [--quick] [--out benchmarks/results/events.md]

For slider_crank (0.5 mm, LN, no friction) and slider_crank_olyaei at 0.1 mm clearance (LN,
Ambrosio friction mu = 0.1), at rtol 1e-8, 1e-10, 1e-12, ``simulate`` from the assembled state
over ``REVS`` crank revolutions with ``event_samples`` = 0 (the step's ends only, nld before
item 5) and the default (``nld.integrators.EVENT_SAMPLES``) and dop853 with the default as an
independent integrator. Per revolution: contact onsets (events with direction +1 at a clearance
joint), all events, accepted steps, rhs evaluations, event-function evaluations are not counted
separately (they are in the CPU time). CPU: process time of the ``simulate`` call, minimum over
``REPEATS`` (after a warm-up that compiles); ratios against event_samples 0 at the same rtol:
CPU per revolution, accepted steps, CPU per accepted step (the cost of the samples themselves:
slider_crank is chaotic, so two runs take different paths and different numbers of steps).

Window check: the journal centre (B.ex, B.ey) over the first ``WINDOW`` revolutions against
dop853 at rtol 1e-12 with the default sampling, divided by the clearance (max over the window),
and the onset times of the window against that reference: which runs find the same onsets.

No timed asserts: the tables go to the results file with the machine and the load.
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

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT))

from nld.integrators import EVENT_SAMPLES  # noqa: E402
from nld.run.simulate import simulate  # noqa: E402

CASES = {
    "slider_crank": (),
    "slider_crank_olyaei c=0.1mm": ("joints.B.clearance=1e-4",),
}
SCENE = {"slider_crank": "slider_crank", "slider_crank_olyaei c=0.1mm": "slider_crank_olyaei"}
RTOLS = (1e-8, 1e-10, 1e-12)
REVS = 20.0
REPEATS = 3
WINDOW = 0.5


def run(case, rtol, m, method="dopri5", revs=REVS, spr=36):
    ov = list(CASES[case])
    c0 = time.process_time()
    r = simulate(SCENE[case], revs=revs, rtol=rtol, overrides=ov, event_samples=m, method=method,
                 samples_per_rev=spr, progress=False)
    cpu = time.process_time() - c0
    return r, cpu


def onsets(r):
    ev = r.events
    return ev[(ev.direction == 1) & (ev.joint == "B")]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="2 revolutions, one repeat")
    ap.add_argument("--out", default=None)
    a = ap.parse_args(argv)
    revs = 2.0 if a.quick else REVS
    repeats = 1 if a.quick else REPEATS
    start = time.time()
    load0 = os.getloadavg()
    lines = []
    w = lines.append
    samples = (0, EVENT_SAMPLES)
    for case in CASES:
        run(case, 1e-6, 0, revs=0.01)                     # compile / load the kernel
        run(case, 1e-6, EVENT_SAMPLES, method="dop853", revs=0.01)
        w(f"### {case}, {revs:g} revolutions from the assembled state\n")
        w("| rtol | method | event_samples | onsets/rev | events/rev | steps/rev | rhs/rev | "
          "CPU ms/rev | us/step | CPU ratio | steps ratio | us/step ratio | status |")
        w("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
        for rtol in RTOLS:
            base = None
            for method, m in [("dopri5", s) for s in samples] + [("dop853", EVENT_SAMPLES)]:
                cpus = []
                for _ in range(repeats):
                    r, cpu = run(case, rtol, m, method, revs)
                    cpus.append(cpu)
                cpu = min(cpus)
                st = r.stats
                row = dict(on=len(onsets(r)) / revs, ev=len(r.events) / revs,
                           steps=st["accepted"] / revs, rhs=st["rhs"] / revs, cpu=cpu / revs)
                if method == "dopri5" and m == 0:
                    base = row
                row["us"] = 1e6 * row["cpu"] / row["steps"]
                dp = method == "dopri5"
                ratio = f"{row['cpu'] / base['cpu']:.2f}" if dp else "–"
                sratio = f"{row['steps'] / base['steps']:.2f}" if dp else "–"
                uratio = f"{row['us'] / base['us']:.2f}" if dp else "–"
                w(f"| {rtol:g} | {method} | {m} | {row['on']:.2f} | {row['ev']:.2f} | "
                  f"{row['steps']:.0f} | {row['rhs']:.0f} | {1e3 * row['cpu']:.2f} | "
                  f"{row['us']:.2f} | {ratio} | {sratio} | {uratio} | {r.status} |")
                print(lines[-1], flush=True)
        w("")
        # window check against dop853 at 1e-12 with the default sampling
        ref, _ = run(case, 1e-12, EVENT_SAMPLES, "dop853", WINDOW, spr=20000)
        clearance = 1e-4 if "1e-4" in " ".join(CASES[case]) else 5e-4
        ref_on = onsets(ref).t.values
        w(f"Window {WINDOW:g} rev against dop853 rtol 1e-12 (event_samples {EVENT_SAMPLES}): "
          f"{len(ref_on)} onsets in the reference.\n")
        w("| rtol | event_samples | journal error / c | onsets | onsets matched (to 1e-4 rev) |")
        w("|---|---|---|---|---|")
        per = ref.table.t.values[-1] / WINDOW
        for rtol in RTOLS:
            for m in samples:
                r, _ = run(case, rtol, m, "dopri5", WINDOW, spr=20000)
                err = np.hypot(r.table["B.ex"].values - ref.table["B.ex"].values,
                               r.table["B.ey"].values - ref.table["B.ey"].values).max() / clearance
                on = onsets(r).t.values
                matched = sum(np.any(np.abs(ref_on - t) < 1e-4 * per) for t in on)
                w(f"| {rtol:g} | {m} | {err:.2e} | {len(on)} | {matched} |")
                print(lines[-1], flush=True)
        w("")
    load1 = os.getloadavg()
    import numba
    head = [f"# Event location: interior samples of each step (benchmarks/bench_events.py)\n",
            f"Machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores; "
            f"Python {platform.python_version()}, numba {numba.__version__}, numpy "
            f"{np.__version__}; {datetime.datetime.utcnow():%Y-%m-%d %H:%M} UTC. Load average "
            f"{' '.join(f'{x:.2f}' for x in load0)} at the start, "
            f"{' '.join(f'{x:.2f}' for x in load1)} at the end (shared machine); run took "
            f"{time.time() - start:.0f} s.\n",
            f"event_samples 0: the step's ends only; {EVENT_SAMPLES}: the default (interior "
            f"samples of the dense output, nld.integrators.events). CPU ratio and steps ratio: "
            f"against event_samples 0 at the same rtol. CPU is the process time of the "
            f"simulate call, minimum over {repeats} repeats.\n"]
    text = "\n".join(head + lines) + "\n"
    if a.out:
        Path(a.out).write_text(text)
    print(text)


if __name__ == "__main__":
    main()
