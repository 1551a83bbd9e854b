#!/usr/bin/env python
"""The excavator study's analysis phase with its route to chaos run after the sweep (in the main
process, one core idle) against beside it (nld.study.background: a process of its own from the
start), side by side in one run (issue 40's 10-minute main job).

    python benchmarks/bench_route_beside_sweep.py [--repeats 2] [--out results/route_beside_sweep.md]

Both variants run studies/zhang2013_excavator.analysis_and_route on 2 workers with the QUICK
analysis settings and the quick route (the period-1 orbit at 3 µm); a warm-up run of each first
(compilation excluded). The variants alternate (after, beside, after, beside ...) so that a change
in the machine's load is not read as a change of speed; reported: wall time of each run, the
minimum per variant and the ratio beside / after with the spread of the per-pair ratios.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "studies"))

import zhang2013_excavator as z  # noqa: E402
from nld.study import background  # noqa: E402


class _Quiet:
    mode = "quick"

    def stage(self, *a, **k):
        pass


def once(beside: bool) -> float:
    an = dict(z.ANALYSIS_QUICK)
    t0 = time.perf_counter()
    with background(z.run_routes, "quick", enabled=beside) as job:
        z.analysis_and_route(_Quiet(), an, 2, job if beside else None)
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args()
    once(False), once(True)                       # warm-up: kernels compiled and cached
    after, beside = [], []
    for _ in range(a.repeats):
        after.append(once(False))
        beside.append(once(True))
    ratios = [b / s for b, s in zip(beside, after)]
    lines = ["| variant | wall s per run | min |", "|---|---|---|",
             f"| route after the sweep | {', '.join(f'{x:.1f}' for x in after)} | {min(after):.1f} |",
             f"| route beside it (own process) | {', '.join(f'{x:.1f}' for x in beside)} | "
             f"{min(beside):.1f} |",
             "", f"ratio beside / after: {min(beside) / min(after):.3f} (per pair "
             f"{min(ratios):.3f} … {max(ratios):.3f})"]
    text = "\n".join(lines)
    print(text)
    if a.out:
        a.out.write_text(__doc__.split("\n\n")[0] + "\n\n" + text + "\n")


if __name__ == "__main__":
    main()
