#!/usr/bin/env python
"""The attractor census's cost (issue 25, item 9); writes benchmarks/results/census.md.

    python benchmarks/bench_census.py [--starts 32] [--dask]

1. A 32-start census of one slider_crank_olyaei point (c = 0.2 mm, mu = 0: chaotic impacting, about
   4 contact onsets per revolution), 50 transient + 100 recorded revolutions per start at rtol
   1e-10 (the census defaults), on the local process pool of 2 workers (target <= 2 min on 2
   cores), and the same on 1 worker: the parallel efficiency T1 / (2 T2). The two results must be
   identical (checked, reported).
2. With --dask: the same census on a Dask LocalCluster of 1 and 2 worker processes (1 thread
   each), the cluster started before the clock; T(1) / T(N) is the scaling (a census is
   embarrassingly parallel over its starts: each start is a task; the exponents of the attractors
   are a second, short round).

The machine's load (os.getloadavg()) is written beside each time: on a shared machine rerun idle.
"""
from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

OVERRIDES = ["joints.B.clearance=2e-4", "joints.B.friction.mu=0"]


def timed_census(starts, workers=1, dask=None):
    from nld.analysis.attractors import census
    from nld.systems.core import SceneSystem
    s = SceneSystem("slider_crank_olyaei", OVERRIDES)
    t0 = time.perf_counter()
    r = census(s, starts, workers=workers, dask=dask, progress=False)
    return time.perf_counter() - t0, r


def summary(r) -> str:
    return "; ".join(f"{a.kind} {a.count}/{r.n_starts}, λ1 {a.lambda1:.3g} ± "
                     f"{a.lambda1_uncertainty:.2g}" for a in r.attractors) + (
        f"; unsettled {r.unsettled}" if r.unsettled else "")


def main() -> None:
    from _results import write_table
    ap = argparse.ArgumentParser()
    ap.add_argument("--starts", type=int, default=32)
    ap.add_argument("--dask", action="store_true")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "census.md"))
    a = ap.parse_args()
    timed_census(2, workers=1)                                  # compile / load the kernel
    rows = []
    load0 = os.getloadavg()[0]
    t2, r2 = timed_census(a.starts, workers=2)
    rows.append(f"| local pool, 2 workers | {t2:.1f} | {load0:.1f} | {summary(r2)} |")
    print(rows[-1], flush=True)
    load0 = os.getloadavg()[0]
    t1, r1 = timed_census(a.starts, workers=1)
    rows.append(f"| this process, 1 worker | {t1:.1f} | {load0:.1f} | {summary(r1)} |")
    print(rows[-1], flush=True)
    same = summary(r1) == summary(r2) and list(r1.runs["attractor"]) == list(r2.runs["attractor"])
    tail = [f"", f"Parallel efficiency T1 / (2 T2) = {t1 / (2 * t2):.2f}; the two censuses are "
                 f"{'identical' if same else 'DIFFERENT'} (kinds, counts, λ1, labels per start)."]
    if a.dask:
        from distributed import Client, LocalCluster
        times = {}
        for n in (1, 2):
            with LocalCluster(n_workers=n, threads_per_worker=1, processes=True) as cl, \
                    Client(cl) as client:
                timed_census(2, dask=client)                     # warm the workers
                load0 = os.getloadavg()[0]
                times[n], rd = timed_census(a.starts, dask=client)
                rows.append(f"| Dask LocalCluster, {n} worker(s) | {times[n]:.1f} | {load0:.1f} | "
                            f"{summary(rd)} |")
                print(rows[-1], flush=True)
        tail.append(f"Dask scaling T(1) / T(2) = {times[1] / times[2]:.2f} (ideal 2).")
    head = ["# Attractor census: cost", "",
            f"`python benchmarks/bench_census.py{' --dask' if a.dask else ''}` on "
            f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores: a "
            f"{a.starts}-start census of slider_crank_olyaei with {', '.join(OVERRIDES)}, the census "
            f"defaults (50 transient + 100 recorded revolutions per start, rtol 1e-10, λ1 on up to 2 "
            f"runs per attractor over 100 revolutions). Target: <= 120 s on 2 cores.", "",
            "| where | wall [s] | load before | result |", "|---|---|---|---|"]
    write_table(a.out, head, rows + tail)


if __name__ == "__main__":
    main()
